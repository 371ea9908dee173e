//! The progress bars of every command (stderr): runs done of a study, or the fraction of one
//! run.

use indicatif::{ProgressBar, ProgressStyle};
use std::time::Duration;

/// Resolution of a single run's bar.
const STEPS: u64 = 1000;

/// Counts finished runs of a sweep or an optimization (`~`: an estimate of the total).
pub fn runs(total: u64, estimate: bool) -> ProgressBar {
    let template = if estimate {
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/~{len} runs (ETA {eta})"
    } else {
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs (ETA {eta})"
    };
    styled(ProgressBar::new(total), template)
}

/// Shows the fraction of one run done (set with [`set_fraction`]).
pub fn run() -> ProgressBar {
    styled(
        ProgressBar::new(STEPS),
        "{spinner} [{elapsed_precise}] {bar:40} {percent}% of the run (ETA {eta})",
    )
}

/// Moves a single run's bar to `fraction` of the run.
pub fn set_fraction(bar: &ProgressBar, fraction: f64) {
    bar.set_position((fraction.clamp(0.0, 1.0) * STEPS as f64) as u64);
}

fn styled(bar: ProgressBar, template: &str) -> ProgressBar {
    bar.set_style(ProgressStyle::with_template(template).expect("static template"));
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}
