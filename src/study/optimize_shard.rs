//! An optimization split over processes in lockstep (`magopt optimize --shard I/N`, every
//! shard with the same `--out` on a shared file system, e.g. a Slurm array).
//!
//! Every shard runs the same deterministic loop (the Bayesian loop, scan + Brent and
//! Nelder–Mead are functions of the seed and the observations). Of each batch's (point,
//! replicate) runs, shard I runs those at positions j ≡ I (mod N) and saves them; it reads the
//! others from the run files the other shards save, waiting for them. So all shards see the
//! same observations, propose the same next batch and end with the same optimum; shard 0
//! writes the result tables. Each shard holds its own lock file and keeps its modification
//! time fresh (a heartbeat); a shard waiting for runs of a peer whose lock is missing or older
//! than the timeout stops with an error naming the peer, and re-running the shards resumes
//! from the saved runs. Each lock also carries a hash of what its shard runs (the model's code
//! and the study's text), so that shards started with different studies or builds, which
//! would each wait for runs the other never makes, stop with an error instead.

use std::path::Path;
use std::time::{Duration, Instant};

use super::records::{self, RunRecord};
use super::runner::Shard;
use super::spec::{fnv1a, RunSpec};
use crate::output::guard::{age_s, lock_note, DirLock, Heartbeat};
use crate::{Error, Result};

/// How long between looks for a peer's run file.
const POLL: Duration = Duration::from_millis(200);

/// This process's shard and how long it waits for a silent peer.
#[derive(Debug, Clone, Copy)]
pub struct ShardWait {
    /// This shard.
    pub shard: Shard,
    /// Seconds a peer's lock may go untouched (or be missing) before waiting for it fails.
    pub timeout_s: f64,
}

/// The lock and heartbeat a shard holds while it runs.
#[derive(Debug)]
pub struct ShardLock {
    _beat: Heartbeat,
    _lock: DirLock,
}

impl ShardWait {
    /// The lock file of shard `index`.
    fn lock_name(&self, index: usize) -> String {
        format!(".magopt.shard-{index}-of-{}.lock", self.shard.count)
    }

    /// Takes this shard's lock of `dir`, noting a hash of `key` (what it runs), and starts its
    /// heartbeat.
    pub fn hold(&self, dir: &Path, key: &str) -> Result<ShardLock> {
        let note = format!("study={:016x}", fnv1a(key));
        let lock = DirLock::acquire_named(dir, &self.lock_name(self.shard.index), &note)?;
        Ok(ShardLock {
            _beat: Heartbeat::start(lock.path()),
            _lock: lock,
        })
    }

    /// Whether this shard runs the batch's j-th run.
    pub fn runs(&self, j: usize) -> bool {
        j % self.shard.count == self.shard.index
    }

    /// The record of the batch's j-th run, which another shard runs: read from `dir` as soon
    /// as it is saved.
    pub fn wait(&self, dir: &Path, run: &RunSpec, j: usize) -> Result<RunRecord> {
        let peer = j % self.shard.count;
        let lock = dir.join(self.lock_name(peer));
        let start = Instant::now();
        let mine = lock_note(&dir.join(self.lock_name(self.shard.index)));
        loop {
            if let (Some(saved), _) = records::load(dir, &run.id)? {
                return Ok(RunRecord {
                    run: run.clone(),
                    ..saved
                });
            }
            let silent = age_s(&lock).is_none_or(|age| age > self.timeout_s);
            if !silent && lock_note(&lock).is_some_and(|theirs| Some(&theirs) != mine.as_ref()) {
                return Err(Error::input(format!(
                    "shard {peer}/{n} runs another study or magopt build than shard {me}/{n} \
                     (their locks {} and {} differ): start every shard with the same study \
                     file and binary",
                    lock.display(),
                    self.lock_name(self.shard.index),
                    n = self.shard.count,
                    me = self.shard.index,
                )));
            }
            if silent && start.elapsed().as_secs_f64() > self.timeout_s {
                return Err(Error::Output(format!(
                    "shard {peer}/{} is not running (its lock {} is missing or untouched for {} s) \
                     and its run {} is missing: start that shard again (saved runs are reused)",
                    self.shard.count,
                    lock.display(),
                    self.timeout_s,
                    run.id
                )));
            }
            std::thread::sleep(POLL);
        }
    }
}
