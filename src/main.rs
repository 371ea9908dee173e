//! The `magopt` command line: a thin layer over the library.

fn main() {
    quiet_on_closed_pipe();
    std::process::exit(magopt::cli::main());
}

/// Restores the default action of SIGPIPE (Rust ignores it, so `println!` into a closed pipe,
/// as in `magopt blast | head -1`, would panic): the process then ends quietly when its
/// reader goes away, like other Unix tools.
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13;
    const SIG_DFL: usize = 0;
    // SAFETY: setting a signal's disposition to its default at start-up, before any thread
    // exists, has no other effect.
    unsafe {
        signal(SIGPIPE, SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}
