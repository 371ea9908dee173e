//! Analysis of `bed` and `damper` runs (issue 5, items 4 and 2): a cycle records n5/n6/n7,
//! Ψ6, hexagon regularity and cells counted at compression start, maximum compression and end;
//! they equal `analysis::structure::analyze` on the written snapshots; a bed without counted
//! cells leaves them None; the study model lists them. A damper run fits its second motion with
//! both oscillators, and its first fall in the source's normalization.

use magopt::analysis::snapshot::Snapshot as AnalysisSnapshot;
use magopt::analysis::structure::analyze;
use magopt::models::bed::damper::run_damper;
use magopt::models::bed::damper_fit::{fit_damper, FIT_SAMPLES};
use magopt::models::bed::params::{BedParams, Friction, Heights, Preset};
use magopt::models::bed::protocol::run_cycle;
use magopt::models::bed::study::BedModel;
use magopt::models::bed::{STRUCTURE_METRICS, STRUCTURE_STAGES};
use magopt::study::model::{RunContext, StudyModel};

/// A 46-disc bi-disperse bed (R = 0.5, a = 0.75) at 50 mm/s: a cycle in well under a second.
fn small_bidisperse() -> BedParams {
    let mut p = BedParams::defaults();
    p.preset = Preset::Bidisperse;
    p.mixing_ratio = 0.5;
    p.aspect_ratio = 0.75;
    p.particles = Some(46);
    p.piston_speed = 0.05;
    p.relaxation_time = 1.0;
    p.piston_decay_time = 0.2;
    p.settle_time = 0.5;
    p
}

fn metric(metrics: &[(&str, Option<f64>)], name: &str) -> Option<f64> {
    metrics.iter().find(|(n, _)| *n == name).unwrap().1
}

#[test]
fn run_metrics_equal_the_analysis_of_the_written_snapshots() {
    let p = small_bidisperse();
    let o = run_cycle(&p, 3, &|_| {});
    assert!(o.failure.is_none(), "{:?}", o.failure);
    assert!(o.warnings.is_empty(), "{:?}", o.warnings);
    let metrics = o.metrics();
    let dir = std::env::temp_dir().join(format!("magopt-bed-structure-{}", std::process::id()));
    for (k, (_, label)) in STRUCTURE_STAGES.iter().enumerate() {
        let snapshot = o.snapshots.iter().find(|s| s.label == *label).unwrap();
        snapshot.write(&dir, label).unwrap();
        let read = AnalysisSnapshot::read(&dir.join(format!("{label}.parquet"))).unwrap();
        let m = analyze(&read.positions).unwrap();
        let expected = [
            m.n5,
            m.n6,
            m.n7,
            m.psi6,
            m.hexagon_regularity_mean,
            m.hexagon_regularity_std,
            m.cells_counted as f64,
            m.psi6_all,
        ];
        assert!(m.cells_counted > 0, "{label}: no cells counted");
        for (name, want) in STRUCTURE_METRICS[k].iter().zip(expected) {
            assert_eq!(metric(&metrics, name), Some(want), "{name}");
        }
        assert!((m.n5 + m.n6 + m.n7 - 1.0).abs() < 1e-12, "{label}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_bed_without_counted_cells_leaves_the_structure_empty() {
    // Four discs: no Voronoi cell passes the border rule. The structure metrics are None (an
    // analysis error would be a warning, see the unit test in models/bed/mod.rs); the run
    // itself completes and its force metrics exist.
    let mut p = BedParams::defaults();
    p.particles = Some(4);
    p.max_packing_fraction = Some(0.2);
    p.piston_speed = 0.05;
    p.relaxation_time = 1.0;
    p.piston_decay_time = 0.2;
    p.settle_time = 0.5;
    let o = run_cycle(&p, 1, &|_| {});
    assert!(o.failure.is_none(), "{:?}", o.failure);
    let metrics = o.metrics();
    assert!(metric(&metrics, "max_piston_force_N").is_some());
    for names in STRUCTURE_METRICS {
        assert_eq!(metric(&metrics, names[1]), None, "{}", names[1]);
    }
    for (k, stage) in o.structure.iter().enumerate() {
        match stage {
            Some(m) => assert_eq!(m.cells_counted, 0),
            None => assert!(
                o.warnings.iter().any(|w| w.contains(STRUCTURE_STAGES[k].1)),
                "{:?}",
                o.warnings
            ),
        }
    }
    assert!(o.failure.is_none(), "{:?}", o.failure);
}

#[test]
fn the_bed_study_model_sweeps_the_structure_metrics() {
    let model = BedModel::cycle();
    for names in STRUCTURE_METRICS {
        for name in names {
            assert!(model.metrics().contains(&name), "{name}");
        }
    }
    let mut p = small_bidisperse();
    p.mixing_ratio = 0.0;
    let r = model.run(&p, 1, &RunContext::QUIET).unwrap();
    assert!(r.status.is_ok(), "{:?}", r.status);
    let n6 = r.metrics.iter().find(|(n, _)| n == "n6_max").unwrap().1;
    assert!(n6.is_some_and(|v| (0.0..=1.0).contains(&v)), "{n6:?}");
}

/// Times of the upward crossings of z = z_rest, s.
fn upward_crossings(z: &[(f64, f64)]) -> Vec<f64> {
    z.windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .collect()
}

#[test]
fn damper_motion_is_fitted_by_both_oscillators() {
    let mut p = BedParams::defaults();
    p.heights = Heights::PackingFractions; // the piston starts low: a short first fall
    p.particles = Some(24);
    p.relaxation_time = 1.0;
    p.piston_decay_time = 0.2;
    p.settle_time = 0.5;
    p.friction = Friction::Viscous;
    p.damper_time = 1.0;
    p.piston_mass = 0.2;
    let o = run_damper(&p, 1, &|_| {});
    assert!(o.failure.is_none(), "{:?}", o.failure);
    let fits = o.damper_fits.as_ref().expect("fits");
    let z = o.series.get("piston_displacement");
    // Both residuals are small against the 0.2 D swing (the bed is a nearly linear spring
    // at this amplitude); the linear damping is positive (the viscous drag dissipates).
    for (name, fit) in [("linear", &fits.linear), ("Van der Pol", &fits.van_der_pol)] {
        let relative = fit.rmse * fits.length_unit / fits.amplitude;
        assert!(
            relative < 0.05,
            "{name}: rms residual {relative} of the amplitude"
        );
    }
    assert!(fits.linear.param("lambda") > 0.0);
    // The fitted ω agrees with the period of the upward crossings of the rest height
    // (independent of the fit): ω² = ω_d² + λ².
    let up = upward_crossings(z);
    assert!(up.len() >= 3, "{up:?}");
    let period = (up[up.len() - 1] - up[0]) / (up.len() - 1) as f64;
    let lambda = fits.linear.param("lambda");
    let omega = ((2.0 * std::f64::consts::PI / period).powi(2) + lambda * lambda).sqrt();
    for fit in [&fits.linear, &fits.van_der_pol] {
        let fitted = fit.param("omega");
        assert!((fitted / omega - 1.0).abs() < 0.02, "{fitted} vs {omega}");
    }
    let metrics = o.metrics();
    assert_eq!(metric(&metrics, "damper_linear_lambda_per_s"), Some(lambda));
    // Thinning the record for the fit (FIT_SAMPLES) leaves ω and λ as the full record gives
    // them, within a few standard errors.
    assert!(z.len() > FIT_SAMPLES, "{} samples", z.len());
    let rest = o.damper_rest_height.unwrap();
    let full = fit_damper(&o.series, rest, 6e-3, usize::MAX).unwrap();
    assert!(full.time.len() == z.len() && fits.time.len() <= FIT_SAMPLES);
    for name in ["omega", "lambda"] {
        let (a, b) = (fits.linear.param(name), full.linear.param(name));
        let k = fits.linear.names.iter().position(|n| *n == name).unwrap();
        let sigma = fits.linear.std_errors[k];
        assert!(
            (a - b).abs() < 3.0 * sigma,
            "{name}: {a} vs {b} (σ {sigma})"
        );
    }
    // The first fall in the source's units (de Paula 2025, Fig. 5.12): z starts at 1, and the
    // equilibrium g0/ω² of the fitted Eq. (5.12) is the measured rest height over z(0).
    let fall = o.damper_fall_fit.as_ref().expect("first-fall fit");
    assert!((fall.height[0] - 1.0).abs() < 1e-12);
    let v = &fall.van_der_pol;
    let equilibrium = v.param("g0") / v.param("omega").powi(2);
    let z_rest = rest / fall.height_unit;
    assert!(
        (equilibrium / z_rest - 1.0).abs() < 0.05,
        "{equilibrium} vs {z_rest}"
    );
    assert_eq!(
        metric(&metrics, "damper_fall_vdp_alpha"),
        Some(v.param("alpha"))
    );
}
