//! The heap's live bytes, counted: the allocator `magopt` runs with, so that `magopt bench`
//! can report the peak of what a run holds beside the peak resident set, which also holds
//! what the C allocator keeps after frees (results/bench/README.md, "Memory per particle,
//! counted").

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// The system allocator, counting the bytes it has handed out and not yet taken back.
pub struct CountingAllocator;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grown(bytes: usize) {
    let live = LIVE.fetch_add(bytes, Relaxed) + bytes;
    PEAK.fetch_max(live, Relaxed);
}

// SAFETY: every call is passed on to `System` unchanged; the counters only observe it.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            grown(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            grown(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        LIVE.fetch_sub(layout.size(), Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Relaxed);
            grown(new_size);
        }
        p
    }
}

/// Starts a new peak from the bytes live now.
pub(super) fn reset_peak() {
    PEAK.store(LIVE.load(Relaxed), Relaxed);
}

/// The most bytes live at once since the last [`reset_peak`], MB; NaN where the process does
/// not run with [`CountingAllocator`] (the library's tests).
pub(super) fn peak_mb() -> f64 {
    match PEAK.load(Relaxed) {
        0 => f64::NAN,
        bytes => bytes as f64 / (1024.0 * 1024.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_counter_follows_allocations_and_frees() {
        let layout = Layout::from_size_align(4096, 8).unwrap();
        let before = LIVE.load(Relaxed);
        // SAFETY: a fresh layout of non-zero size, freed with the same layout.
        unsafe {
            let p = CountingAllocator.alloc(layout);
            assert!(!p.is_null());
            assert!(PEAK.load(Relaxed) >= before + 4096);
            let q = CountingAllocator.realloc(p, layout, 8192);
            CountingAllocator.dealloc(q, Layout::from_size_align(8192, 8).unwrap());
        }
        // Other tests' threads allocate through `System` directly, not through this counter.
        assert_eq!(LIVE.load(Relaxed), before);
    }
}
