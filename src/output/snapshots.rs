//! Snapshot schedules: which particle frames a run writes, in which formats, and where.
//!
//! A run with an output directory writes its model's own moments (bed: start of compression,
//! maximum compression, end; blast: start, middle, end; align: start, end) as
//! `snapshots/<label>.<ext>`, and the frames a [`Schedule`] asks for (every k steps, at chosen
//! times) as `snapshots/frame.<k>.<ext>` (k = 00000, 00001, …, so that OVITO's and ParaView's
//! file-sequence patterns `frame.*.dump` match them). Each file is written atomically the moment
//! its frame is taken; all frames also go, in time order, into the multi-frame
//! `snapshots/trajectory.xyz`, which is appended to `trajectory.xyz.part` as the run goes and
//! renamed when it ends.
//!
//! A schedule is checked before any computation ([`Schedule::check`]): times must lie in
//! [0, end of the run], and at most [`MAX_FRAMES`] frames may be asked for where the step count
//! is known beforehand. Where it is not (adaptive time steps), a run stops writing at
//! [`MAX_FRAMES`] frames and says so in a note.

use std::io::Write as _;
use std::path::{Path, PathBuf};

pub use super::particles::Format;
use super::particles::ParticleFrame;
use crate::units::{parse_quantity, Dimension};
use crate::{Error, Result};

/// Most frames one run writes.
pub const MAX_FRAMES: usize = 10_000;

/// Which frames a run writes besides its model's own moments.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// A frame every this many steps (step 0 included).
    pub every: Option<u64>,
    /// Frames at these simulated times, s, ascending: each is the first step at or after it.
    pub times: Vec<f64>,
    /// Formats of every frame.
    pub formats: Vec<Format>,
}

impl Default for Schedule {
    fn default() -> Self {
        Self {
            every: None,
            times: Vec::new(),
            formats: Format::ALL.to_vec(),
        }
    }
}

/// What a model knows about a run before it starts, to check a schedule against.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunSpan {
    /// Simulated time at which the run ends at the latest, s.
    pub end: Option<f64>,
    /// Steps the run takes at most, where known beforehand (fixed time step).
    pub steps: Option<u64>,
}

impl Schedule {
    /// No frames of its own and no formats: what a run without files gets.
    pub const NONE: Schedule = Schedule {
        every: None,
        times: Vec::new(),
        formats: Vec::new(),
    };

    /// True if it asks for no frames of its own.
    pub fn is_empty(&self) -> bool {
        self.every.is_none() && self.times.is_empty()
    }

    /// Parses comma-separated times (s, ms, us, min, h; bare number: s), sorted ascending.
    pub fn parse_times(text: &str) -> std::result::Result<Vec<f64>, String> {
        let mut times = text
            .split(',')
            .map(|t| parse_quantity(t.trim(), Dimension::Time, "s"))
            .collect::<std::result::Result<Vec<f64>, String>>()?;
        if let Some(t) = times.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(format!("{t} s is not allowed (need times ≥ 0 s)"));
        }
        times.sort_by(f64::total_cmp);
        times.dedup();
        Ok(times)
    }

    /// Checks the schedule against a run before it starts: every time within [0, end], and
    /// at most [`MAX_FRAMES`] frames where the step count is known.
    pub fn check(&self, span: &RunSpan) -> std::result::Result<(), String> {
        if self.every == Some(0) {
            return Err("snapshot every 0 steps is not allowed (need ≥ 1)".into());
        }
        if let (Some(end), Some(t)) = (span.end, self.times.last()) {
            if *t > end * (1.0 + 1e-12) {
                return Err(format!(
                    "snapshot time {t} s is beyond the end of the run ({end} s)"
                ));
            }
        }
        let from_every = match (self.every, span.steps) {
            (Some(k), Some(steps)) => steps / k + 1,
            _ => 0,
        };
        let frames = from_every + self.times.len() as u64;
        if frames > MAX_FRAMES as u64 {
            return Err(format!(
                "the schedule asks for {frames} frames (limit {MAX_FRAMES}): snapshot less often"
            ));
        }
        Ok(())
    }
}

/// Creates `dir` and checks that a file can be written there, before a run starts.
pub fn check_writable(dir: &Path) -> Result<()> {
    let fail = |e: std::io::Error| {
        Error::input(format!(
            "snapshot directory '{}' is not writable: {e}",
            dir.display()
        ))
    };
    std::fs::create_dir_all(dir).map_err(fail)?;
    let probe = dir.join(".magopt-write-probe");
    std::fs::write(&probe, b"").map_err(fail)?;
    std::fs::remove_file(&probe).map_err(fail)
}

/// Writes one run's frames as they are taken (see the module documentation).
pub struct Recorder<'a> {
    dir: PathBuf,
    schedule: &'a Schedule,
    /// Index of the next scheduled time not yet written.
    next_time: usize,
    /// Scheduled frames written.
    frames: usize,
    /// The step of the latest scheduled frame (a step is written once).
    last_step: Option<u64>,
    trajectory: Option<std::fs::File>,
    error: Option<Error>,
    notes: Vec<String>,
}

impl<'a> Recorder<'a> {
    /// A recorder writing into `<artifacts>/snapshots`.
    pub fn new(artifacts: &Path, schedule: &'a Schedule) -> Self {
        Self {
            dir: artifacts.join("snapshots"),
            schedule,
            next_time: 0,
            frames: 0,
            last_step: None,
            trajectory: None,
            error: None,
            notes: Vec::new(),
        }
    }

    /// The scheduled times, s (a model with adaptive steps stops at them).
    pub fn times(&self) -> &[f64] {
        &self.schedule.times
    }

    /// The step stride of the schedule, if any.
    pub fn every(&self) -> Option<u64> {
        self.schedule.every
    }

    /// Runs `write(dir)` for a file of the run's own (a figure beside a frame) into the
    /// snapshot directory, unless an earlier write failed; keeps the first error.
    pub fn attempt(&mut self, write: impl FnOnce(&Path) -> Result<()>) {
        if self.error.is_none() {
            if let Err(e) = write(&self.dir) {
                self.error = Some(e);
            }
        }
    }

    /// Whether the schedule asks for a frame after `step` steps at simulated time `time` (s).
    /// Every scheduled time up to `time` counts as served by this frame.
    pub fn due(&mut self, step: u64, time: f64) -> bool {
        let every = self.schedule.every.is_some_and(|k| step.is_multiple_of(k));
        let times = &self.schedule.times;
        let mut at_time = false;
        while self.next_time < times.len() && times[self.next_time] <= time * (1.0 + 1e-12) {
            self.next_time += 1;
            at_time = true;
        }
        let due = (every || at_time) && self.error.is_none() && self.last_step != Some(step);
        if due {
            self.last_step = Some(step);
        }
        due
    }

    /// Writes a scheduled frame `frame.<k>.*` taken after `step` steps (up to [`MAX_FRAMES`]).
    pub fn frame(&mut self, step: u64, frame: &ParticleFrame) {
        if self.frames == MAX_FRAMES {
            self.notes.push(format!(
                "snapshot limit of {MAX_FRAMES} frames reached at t = {:.4e} s: later frames \
                 not written",
                frame.time
            ));
        }
        if self.frames >= MAX_FRAMES {
            self.frames += 1;
            return;
        }
        let stem = format!("frame.{:05}", self.frames);
        self.frames += 1;
        self.write(&stem, step, frame);
    }

    /// Writes a model's own moment `<label>.*` taken after `step` steps.
    pub fn moment(&mut self, label: &str, step: u64, frame: &ParticleFrame) {
        self.write(label, step, frame);
    }

    fn write(&mut self, stem: &str, step: u64, frame: &ParticleFrame) {
        if self.error.is_none() {
            if let Err(e) = self.try_write(stem, step, frame) {
                self.error = Some(e);
            }
        }
    }

    fn try_write(&mut self, stem: &str, step: u64, frame: &ParticleFrame) -> Result<()> {
        let xyz = frame.write_formats(&self.dir, stem, step, &self.schedule.formats)?;
        let part = self.dir.join("trajectory.xyz.part");
        if self.trajectory.is_none() {
            let file = std::fs::File::create(&part).map_err(|e| Error::io(&part, e))?;
            self.trajectory = Some(file);
        }
        let file = self.trajectory.as_mut().expect("opened above");
        file.write_all(xyz.as_bytes())
            .map_err(|e| Error::io(&part, e))
    }

    /// Ends the run's output: `trajectory.xyz.part` becomes `trajectory.xyz`. Returns the
    /// notes (a frame limit reached), or the first write error.
    pub fn finish(mut self) -> Result<Vec<String>> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        if let Some(file) = self.trajectory.take() {
            let part = self.dir.join("trajectory.xyz.part");
            file.sync_all().map_err(|e| Error::io(&part, e))?;
            let path = self.dir.join("trajectory.xyz");
            std::fs::rename(&part, &path).map_err(|e| Error::io(&path, e))?;
        }
        Ok(self.notes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_parse_and_reject() {
        assert_eq!(
            Format::parse_list("xyz, dump,xyz").unwrap(),
            vec![Format::Xyz, Format::Dump]
        );
        let e = Format::parse_list("xyz,pdb").unwrap_err();
        assert!(e.contains("'pdb'") && e.contains("allowed"), "{e}");
    }

    #[test]
    fn times_parse_sorted_and_nonnegative() {
        let t = Schedule::parse_times("2 ms, 1e-3,0").unwrap();
        assert_eq!(t, vec![0.0, 1e-3, 2e-3]);
        assert!(Schedule::parse_times("-1 s").unwrap_err().contains("≥ 0"));
        assert!(Schedule::parse_times("1 m").is_err());
    }

    #[test]
    fn check_rejects_late_times_and_too_many_frames() {
        let span = RunSpan {
            end: Some(1.0),
            steps: Some(1_000_000),
        };
        let late = Schedule {
            times: vec![0.5, 2.0],
            ..Schedule::default()
        };
        assert!(late.check(&span).unwrap_err().contains("beyond the end"));
        let dense = Schedule {
            every: Some(10),
            ..Schedule::default()
        };
        assert!(dense.check(&span).unwrap_err().contains("limit"));
        let fine = Schedule {
            every: Some(1000),
            ..Schedule::default()
        };
        assert!(fine.check(&span).is_ok());
        let unknown = RunSpan::default();
        assert!(
            dense.check(&unknown).is_ok(),
            "checked while running instead"
        );
    }

    #[test]
    fn due_serves_every_k_and_each_time_once() {
        let s = Schedule {
            every: Some(3),
            times: vec![0.25, 0.3, 0.9],
            ..Schedule::default()
        };
        let mut r = Recorder::new(Path::new("/nonexistent"), &s);
        let due: Vec<u64> = (0..10u64).filter(|&k| r.due(k, k as f64 * 0.1)).collect();
        // every 3: 0, 3, 6, 9; times 0.25 and 0.3 at step 3 (t = 0.3), 0.9 at step 9.
        assert_eq!(due, vec![0, 3, 6, 9]);
        let times_only = Schedule {
            times: vec![0.25],
            ..Schedule::default()
        };
        let mut r = Recorder::new(Path::new("/nonexistent"), &times_only);
        let due: Vec<u64> = (0..10u64).filter(|&k| r.due(k, k as f64 * 0.1)).collect();
        assert_eq!(due, vec![3]);
    }
}
