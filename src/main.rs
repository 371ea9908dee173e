//! The `magopt` command line: a thin layer over the library.

/// Counts the heap's live bytes for `magopt bench` (one relaxed atomic add per allocation).
#[global_allocator]
static HEAP: magopt::cli::CountingAllocator = magopt::cli::CountingAllocator;

fn main() {
    quiet_on_closed_pipe();
    one_heap_arena();
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

/// Asks glibc's allocator for one arena shared by all threads instead of one per thread: the
/// buffers a rayon worker grows and frees stay in its own arena, so the resident set rose
/// up to 28 % above the heap's live bytes at N = 3·10⁵ and about 20 % at 10⁵, against about
/// 10 MB above them with one arena, at the same speed (results/bench/README.md, "Memory per
/// particle, counted"). Nothing here allocates often enough for the shared lock to matter.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn one_heap_arena() {
    extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }
    const M_ARENA_MAX: i32 = -8;
    // SAFETY: an allocator setting made at start-up, before any thread exists.
    unsafe {
        mallopt(M_ARENA_MAX, 1);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn one_heap_arena() {}
