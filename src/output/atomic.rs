//! Atomic file writes: write a temporary file in the destination directory, fsync it, rename
//! it over the final name. Readers see either the old file or the complete new one.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::{Error, Result};

/// Counter that keeps temporary names unique between threads of one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A temporary path beside `path`: `<path>.tmp-<pid>-<n><suffix>`, in the same directory
/// (so the final rename never crosses file systems). `suffix` lets callers keep an
/// extension that a writer needs (e.g. `".png"`).
pub(crate) fn temp_path_for(path: &Path, suffix: &str) -> PathBuf {
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut name = path.as_os_str().to_owned();
    name.push(format!(".tmp-{}-{n}{suffix}", std::process::id()));
    PathBuf::from(name)
}

/// The directory that holds `path` (`.` for a bare file name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Best-effort fsync of the directory holding `path`, so the rename itself is durable.
fn sync_parent_dir(path: &Path) {
    #[cfg(unix)]
    if let Ok(dir) = File::open(parent_dir(path)) {
        let _ = dir.sync_all();
    }
    #[cfg(not(unix))]
    let _ = path;
}

/// Fsyncs the complete temporary file `tmp` and renames it to `path`. On any failure the
/// temporary file is removed and the error names `path`.
pub(crate) fn commit_temp(tmp: &Path, path: &Path) -> Result<()> {
    let result = File::open(tmp)
        .and_then(|f| f.sync_all())
        .and_then(|()| fs::rename(tmp, path));
    match result {
        Ok(()) => {
            sync_parent_dir(path);
            Ok(())
        }
        Err(e) => {
            let _ = fs::remove_file(tmp);
            Err(Error::io(path, e))
        }
    }
}

/// Write bytes to `path` atomically: write `<path>.tmp-<pid>-<n>` in the same directory,
/// fsync, rename. No half-written file is ever visible under the final name; an existing
/// file at `path` is replaced. The directory must exist.
///
/// # Errors
/// [`Error::Io`] naming `path` if the temporary file cannot be written or renamed (the
/// temporary file is removed in that case).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temp_path_for(path, "");
    let written = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| {
            f.write_all(bytes)?;
            f.sync_all()
        });
    if let Err(e) = written {
        let _ = fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    match fs::rename(&tmp, path) {
        Ok(()) => {
            sync_parent_dir(path);
            Ok(())
        }
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(Error::io(path, e))
        }
    }
}

/// Write `value` as pretty-printed JSON followed by a newline, atomically (see
/// [`write_atomic`]).
///
/// # Errors
/// [`Error::Output`] if the value cannot be serialized; [`Error::Io`] as for [`write_atomic`].
pub fn write_json_atomic(path: &Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| {
        Error::Output(format!(
            "cannot serialize JSON for '{}': {e}",
            path.display()
        ))
    })?;
    text.push('\n');
    write_atomic(path, text.as_bytes())
}

/// Create `dir` (and parents) if needed and check it is writable by creating and removing a
/// probe file.
///
/// # Errors
/// [`Error::Input`] with the message
/// `cannot write to output directory '<dir>': <reason>`.
pub fn prepare_output_dir(dir: &Path) -> Result<()> {
    let fail = |reason: String| {
        Error::input(format!(
            "cannot write to output directory '{}': {reason}",
            dir.display()
        ))
    };
    fs::create_dir_all(dir).map_err(|e| fail(e.to_string()))?;
    if !dir.is_dir() {
        return Err(fail("not a directory".to_string()));
    }
    let probe = dir.join(format!(
        ".magopt-write-probe-{}-{}",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .and_then(|mut f| f.write_all(b"probe"))
        .map_err(|e| {
            let _ = fs::remove_file(&probe);
            fail(e.to_string())
        })?;
    fs::remove_file(&probe).map_err(|e| fail(format!("cannot remove probe file: {e}")))?;
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A fresh, empty directory under the system temp dir, unique to this test and process.
    pub(crate) fn test_dir(name: &str) -> PathBuf {
        let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!(
            "magopt-output-test-{name}-{}-{n}",
            std::process::id()
        ));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn write_atomic_creates_and_replaces_without_leftovers() {
        let dir = test_dir("atomic");
        let path = dir.join("data.bin");
        write_atomic(&path, b"first version").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first version");
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        write_atomic(&path, b"").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"");
        assert_eq!(entries(&dir), vec!["data.bin".to_string()]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn write_atomic_into_missing_dir_is_io_error_without_leftovers() {
        let dir = test_dir("atomic-missing");
        let path = dir.join("no-such-dir").join("x.json");
        let err = write_atomic(&path, b"x").unwrap_err();
        match err {
            Error::Io { path: p, .. } => assert_eq!(p, path),
            other => panic!("unexpected error {other:?}"),
        }
        assert!(entries(&dir).is_empty());
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn write_json_atomic_is_pretty_with_trailing_newline() {
        let dir = test_dir("json");
        let path = dir.join("summary.json");
        let value = serde_json::json!({"a": 1, "b": [1.5, null], "c": "text"});
        write_json_atomic(&path, &value).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.ends_with("}\n"));
        assert!(text.contains("\n  \"a\": 1"));
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(back, value);
        assert_eq!(entries(&dir), vec!["summary.json".to_string()]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn prepare_output_dir_creates_nested_dirs() {
        let dir = test_dir("prepare");
        let out = dir.join("a").join("b");
        prepare_output_dir(&out).unwrap();
        assert!(out.is_dir());
        assert!(entries(&out).is_empty(), "probe file left behind");
        // Idempotent.
        prepare_output_dir(&out).unwrap();
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn prepare_output_dir_under_a_file_is_input_error_naming_path() {
        let dir = test_dir("prepare-bad");
        let file = dir.join("plain-file");
        fs::write(&file, b"x").unwrap();
        let bad = file.join("sub");
        let err = prepare_output_dir(&bad).unwrap_err();
        match &err {
            Error::Input(msg) => {
                assert!(msg.contains(&bad.display().to_string()), "{msg}");
                assert!(
                    msg.starts_with("cannot write to output directory '"),
                    "{msg}"
                );
            }
            other => panic!("unexpected error {other:?}"),
        }
        // The path given is a regular file: also an input error.
        let err = prepare_output_dir(&file).unwrap_err();
        assert!(
            matches!(err, Error::Input(ref m) if m.contains("plain-file")),
            "{err:?}"
        );
        fs::remove_dir_all(&dir).unwrap();
    }
}
