//! A single run with the pool's other workers kept awake (results/bench/README.md, "Single
//! runs with the pool's workers kept awake").
//!
//! rayon's idle workers look for work for a few dozen rounds and then sleep until a new job
//! wakes them, and on a virtual machine a wake-up takes tens of microseconds. A run of 10⁴
//! particles makes several parallel passes per step, a millisecond or less apart, so on two
//! threads its second thread was put to sleep and woken at nearly every pass: at N = 10⁴ on a
//! 2-core VM that cost the bed 5 % and align 2 % of their 2-thread time. Here every other
//! worker runs a job that keeps taking the pool's work (`rayon::yield_now`) until the run
//! ends, yielding the processor between looks, so that no pass waits for a wake-up. The
//! price: those workers use their cores while the run has nothing for them. This changes only
//! where the work runs: the results are the same.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// How long a run waits at its start for the other workers to take their jobs (a wake-up
/// each); a worker that comes later leaves its job at once.
const TAKE_WAIT: Duration = Duration::from_millis(2);

/// In [`Takers`]: the run has started, and no worker may take a job any more.
const STARTED: usize = 1 << (usize::BITS - 1);

/// How many workers took a job of this run, and whether it has started.
type Takers = AtomicUsize;

/// Runs `run` on a worker of the current rayon pool while every other worker of that pool
/// keeps looking for the pool's work instead of sleeping; returns what `run` returns.
///
/// Why it cannot deadlock: a worker that keeps looking holds its thread until the run ends,
/// so it must never sit above a piece of unfinished work on that thread's stack. Every
/// worker takes its job before the run starts (later ones leave it at once), so it can sit
/// above work only of runs that started earlier; a run waits only for runs that started
/// later, and no run can wait for itself through a chain of them. And the run's own thread
/// never keeps looking for its own run.
pub fn with_workers_awake<R: Send>(run: impl FnOnce() -> R + Send) -> R {
    let (takers, done) = (Takers::new(0), AtomicBool::new(false));
    rayon::scope(|scope| {
        let owner = rayon::current_thread_index();
        let others = rayon::current_num_threads() - 1;
        for _ in 0..others {
            let (takers, done) = (&takers, &done);
            scope.spawn(move |_| keep_looking(owner, takers, done));
        }
        let asked = Instant::now();
        while takers.load(Ordering::Acquire) < others && asked.elapsed() < TAKE_WAIT {
            std::thread::yield_now();
        }
        takers.fetch_or(STARTED, Ordering::AcqRel);
        // set when the run returns or unwinds: a panicking run must not leave the workers
        // looking for work forever (the scope waits for them)
        let _finished = Finished(&done);
        run()
    })
}

/// One worker's job: unless it runs on the run's own thread or comes after the run started,
/// takes the pool's work until the run is `done`, yielding the processor between looks.
fn keep_looking(owner: Option<usize>, takers: &Takers, done: &AtomicBool) {
    let take = |n: usize| (n & STARTED == 0).then_some(n + 1);
    let on_own_thread = rayon::current_thread_index() == owner;
    if on_own_thread
        || takers
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, take)
            .is_err()
    {
        return;
    }
    while !done.load(Ordering::Acquire) {
        if rayon::yield_now() != Some(rayon::Yield::Executed) {
            std::thread::yield_now();
        }
    }
}

/// Sets its flag when dropped.
struct Finished<'a>(&'a AtomicBool);

impl Drop for Finished<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    /// A run with the workers awake returns what it computes, on 1, 2 and 4 threads (the sums
    /// do not depend on which workers take the run's loops, so this checks that the result
    /// comes back and that nothing hangs, not how the work was shared).
    #[test]
    fn a_run_gives_the_same_result_with_the_workers_awake() {
        let work = || {
            (0..200)
                .map(|k| {
                    (0..10_000u32)
                        .into_par_iter()
                        .with_max_len(256)
                        .map(|i| (u64::from(i) * u64::from(i) + k) % 7919)
                        .sum::<u64>()
                })
                .collect::<Vec<_>>()
        };
        let plain = pool(1).install(work);
        for threads in [1, 2, 4] {
            assert_eq!(pool(threads).install(|| with_workers_awake(work)), plain);
        }
    }

    /// A run that panics ends the scope (the workers stop looking) and its panic reaches
    /// the caller.
    #[test]
    fn a_panicking_run_does_not_hang() {
        let caught = pool(2).install(|| {
            std::panic::catch_unwind(|| with_workers_awake(|| -> u32 { panic!("run failed") }))
        });
        assert!(caught.is_err());
    }

    /// Runs awake inside runs awake, several at once inside one pool's loop, and several
    /// called at once from outside it, on 2, 4 and 8 threads: all end with their sums.
    #[test]
    fn nested_and_concurrent_runs_end() {
        let sum = |k: u64| {
            (0..5_000u32)
                .into_par_iter()
                .map(|i| u64::from(i) ^ k)
                .sum()
        };
        let expected: Vec<u64> = (0..8u64)
            .map(|k| (0..5_000u64).map(|i| i ^ k).sum())
            .collect();
        for threads in [2, 4, 8] {
            let pool = pool(threads);
            let nested: Vec<u64> = pool.install(|| {
                (0..8u64)
                    .into_par_iter()
                    .map(|k| with_workers_awake(|| with_workers_awake(|| sum(k))))
                    .collect()
            });
            assert_eq!(nested, expected);
            let outside: Vec<u64> = std::thread::scope(|s| {
                let calls: Vec<_> = (0..8u64)
                    .map(|k| {
                        let pool = &pool;
                        s.spawn(move || pool.install(|| with_workers_awake(|| sum(k))))
                    })
                    .collect();
                calls.into_iter().map(|c| c.join().unwrap()).collect()
            });
            assert_eq!(outside, expected);
        }
    }
}
