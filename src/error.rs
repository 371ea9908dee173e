//! The library's one error type. `main` maps every variant to one line and exit code 2.

use std::path::PathBuf;

/// Errors that stop a command. A physics blow-up is *not* an error: it is a failed run
/// recorded in the results (see `models::RunStatus`).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad user input: the message names the offending value and what is allowed.
    #[error("{0}")]
    Input(String),
    /// A file could not be read or written; carries its path.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory involved.
        path: PathBuf,
        /// The underlying IO error.
        source: std::io::Error,
    },
    /// A table or figure could not be produced.
    #[error("{0}")]
    Output(String),
}

impl Error {
    /// Shorthand for an input error.
    pub fn input(msg: impl Into<String>) -> Self {
        Error::Input(msg.into())
    }

    /// Wraps an IO error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result alias used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;
