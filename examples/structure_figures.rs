//! Figures and fits of the bi-disperse structure studies (issue 5): reads the `runs.parquet` of
//! `structure-bidisperse`, `structure-bidisperse-8mm` and `structure-friction` under DIR (as
//! `magopt sweep` writes them), and runs a few cycles with snapshots for the force histograms.
//! Writes PNG figures and `summary.json` (seed means ± standard deviations, bi-exponential fits,
//! Pearson correlations) into DIR.
//!
//! `cargo run --release --example structure_figures -- [DIR] [particles] [speed_mm_per_s] [seeds]`
//! (defaults: results/structure/quick, 100, 22.5, 3; the histogram runs use the same N, speed
//! and seeds as the quick studies; seeds = 0 skips them). Studies absent under DIR are skipped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use magopt::analysis::distribution::{force_distributions, pearson};
use magopt::analysis::fit::curves::bi_exponential;
use magopt::analysis::fit::{Fit, FitSettings};
use magopt::models::bed::params::{BedParams, Preset};
use magopt::models::bed::protocol::run_cycle;
use magopt::output::atomic::write_json_atomic;
use magopt::output::plot::{render_png, Figure, Series, SeriesStyle};
use magopt::output::table::{read_parquet, ColumnData, Table};
use serde_json::{json, Value};

/// One run of a study: its curve label, mixing ratio (realized), seed and metrics.
struct Run {
    group: String,
    r: f64,
    seed: u64,
    metric: BTreeMap<String, f64>,
}

fn numbers(t: &Table, name: &str) -> Vec<f64> {
    match t.column(name) {
        Some(ColumnData::F64(v)) => v.clone(),
        Some(ColumnData::OptF64(v)) => v.iter().map(|x| x.unwrap_or(f64::NAN)).collect(),
        Some(ColumnData::U64(v)) => v.iter().map(|&x| x as f64).collect(),
        Some(ColumnData::I64(v)) => v.iter().map(|&x| x as f64).collect(),
        _ => vec![f64::NAN; t.n_rows()],
    }
}

fn texts(t: &Table, name: &str) -> Vec<String> {
    match t.column(name) {
        Some(ColumnData::Str(v)) => v.clone(),
        _ => vec![String::new(); t.n_rows()],
    }
}

/// The ok runs of `DIR/<study>/runs.parquet`, labelled by `group(row)`.
fn load(dir: &Path, study: &str, group: &dyn Fn(&Table, usize) -> String) -> Vec<Run> {
    let path = dir.join(study).join("runs.parquet");
    let Ok(t) = read_parquet(&path) else {
        eprintln!("skipping {}: not found", path.display());
        return Vec::new();
    };
    let (status, seed, r) = (
        texts(&t, "status"),
        numbers(&t, "seed"),
        numbers(&t, "small_fraction"),
    );
    let columns: Vec<(String, Vec<f64>)> = t
        .columns
        .iter()
        .map(|c| (c.name.clone(), numbers(&t, &c.name)))
        .collect();
    (0..t.n_rows())
        .filter(|&i| status[i] == "ok")
        .map(|i| Run {
            group: group(&t, i),
            r: r[i],
            seed: seed[i] as u64,
            metric: columns
                .iter()
                .map(|(n, v)| (n.clone(), v[i]))
                .filter(|(_, v)| v.is_finite())
                .collect(),
        })
        .collect()
}

/// Mean and sample standard deviation of the finite values.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// Per group: (R, mean, std) of `value(run)` over seeds, R ascending.
type Curve = (String, Vec<(f64, f64, f64)>);

fn curves(runs: &[Run], value: &dyn Fn(&Run) -> f64) -> Vec<Curve> {
    let mut groups: BTreeMap<&str, BTreeMap<i64, Vec<f64>>> = BTreeMap::new();
    for run in runs {
        let key = (run.r * 1e4).round() as i64;
        groups
            .entry(&run.group)
            .or_default()
            .entry(key)
            .or_default()
            .push(value(run));
    }
    groups
        .into_iter()
        .map(|(g, by_r)| {
            let points = by_r
                .into_iter()
                .map(|(k, v)| {
                    let (m, s) = mean_std(&v);
                    (k as f64 / 1e4, m, s)
                })
                .collect();
            (g.to_string(), points)
        })
        .collect()
}

fn series(
    label: &str,
    x: Vec<f64>,
    y: Vec<f64>,
    err: Option<Vec<f64>>,
    style: SeriesStyle,
) -> Series {
    Series {
        label: label.into(),
        x,
        y,
        y_err: err,
        style,
    }
}

fn curve_series(curves: &[Curve], suffix: &str) -> Vec<Series> {
    curves
        .iter()
        .map(|(g, p)| {
            series(
                &format!("{g}{suffix}"),
                p.iter().map(|q| q.0).collect(),
                p.iter().map(|q| q.1).collect(),
                Some(p.iter().map(|q| q.2).collect()),
                SeriesStyle::LinePoints,
            )
        })
        .collect()
}

fn figure(title: &str, y_label: &str, series: Vec<Series>) -> Figure {
    Figure {
        title: title.into(),
        x_label: "mixing ratio R (fraction of small discs)".into(),
        y_label: y_label.into(),
        series,
        ..Figure::default()
    }
}

fn curves_json(curves: &[Curve]) -> Value {
    curves
        .iter()
        .map(|(g, p)| {
            (
                g.clone(),
                json!(p
                    .iter()
                    .map(|q| json!({"R": q.0, "mean": q.1, "std": q.2}))
                    .collect::<Vec<_>>()),
            )
        })
        .collect::<serde_json::Map<_, _>>()
        .into()
}

fn fit_json(fit: &Fit) -> Value {
    json!({
        "parameters": fit.names.iter().zip(&fit.params).map(|(n, p)| (n.to_string(), json!(p))).collect::<serde_json::Map<_, _>>(),
        "rmse": fit.rmse, "r_squared": fit.r_squared,
    })
}

/// F_max / F_max(R = 1) per seed, its seed means and a bi-exponential fit per group.
fn force_ratio(
    runs: &[Run],
    out: &Path,
    summary: &mut serde_json::Map<String, Value>,
) -> magopt::Result<()> {
    let f = |r: &Run| {
        r.metric
            .get("max_piston_force_N")
            .copied()
            .unwrap_or(f64::NAN)
    };
    let at_one: BTreeMap<(String, u64), f64> = runs
        .iter()
        .filter(|r| (r.r - 1.0).abs() < 1e-9)
        .map(|r| ((r.group.clone(), r.seed), f(r)))
        .collect();
    let ratio = |r: &Run| {
        f(r) / at_one
            .get(&(r.group.clone(), r.seed))
            .copied()
            .unwrap_or(f64::NAN)
    };
    let data = curves(runs, &ratio);
    let mut plotted = curve_series(&data, "");
    let mut fits = serde_json::Map::new();
    for (g, p) in &data {
        let (x, y): (Vec<f64>, Vec<f64>) = p.iter().map(|q| (q.0, q.1)).unzip();
        match bi_exponential(&x, &y, &FitSettings::default()) {
            Ok(fit) => {
                let xs: Vec<f64> = (0..=100).map(|k| f64::from(k) / 100.0).collect();
                let (a, l1, b, l2) = (fit.params[0], fit.params[1], fit.params[2], fit.params[3]);
                let ys = xs
                    .iter()
                    .map(|x| a * (l1 * x).exp() + b * (l2 * x).exp())
                    .collect();
                plotted.push(series(
                    &format!("{g}: bi-exponential fit"),
                    xs,
                    ys,
                    None,
                    SeriesStyle::Line,
                ));
                fits.insert(g.clone(), fit_json(&fit));
            }
            Err(e) => eprintln!("{g}: bi-exponential fit failed: {e}"),
        }
    }
    let fig = figure(
        "F_max / F_max(R = 1) versus mixing ratio",
        "F_max / F_max(R = 1)",
        plotted,
    );
    render_png(&out.join("force_ratio_vs_R.png"), &fig)?;
    summary.insert("force_ratio".into(), curves_json(&data));
    summary.insert("force_ratio_bi_exponential".into(), fits.into());
    summary.insert("max_piston_force_N".into(), curves_json(&curves(runs, &f)));
    Ok(())
}

fn metric(name: &'static str) -> impl Fn(&Run) -> f64 {
    move |r: &Run| r.metric.get(name).copied().unwrap_or(f64::NAN)
}

/// One figure per metric and stage, a curve per group; the data into `summary`.
fn metric_figures(
    runs: &[Run],
    out: &Path,
    stem: &str,
    summary: &mut serde_json::Map<String, Value>,
) -> magopt::Result<()> {
    let what = [
        ("n5", "n5 (cells with ≤ 5 sides)"),
        ("n6", "n6 (hexagonal cells)"),
        ("n7", "n7 (cells with ≥ 7 sides)"),
        ("psi6", "Ψ6"),
        ("regularity", "hexagon regularity (mean)"),
        ("cells", "Voronoi cells counted (border rule)"),
        ("max_piston_force_N", "F_max (N)"),
    ];
    for (name, label) in what {
        for stage in ["start", "max", "end"] {
            let key: &'static str = if name == "max_piston_force_N" {
                if stage != "max" {
                    continue;
                }
                name
            } else {
                Box::leak(format!("{name}_{stage}").into_boxed_str())
            };
            let data = curves(runs, &metric(key));
            let fig = figure(
                &format!("{label} at {stage} ({stem})"),
                label,
                curve_series(&data, ""),
            );
            render_png(&out.join(format!("{stem}_{key}_vs_R.png")), &fig)?;
            summary.insert(format!("{stem}/{key}"), curves_json(&data));
        }
    }
    Ok(())
}

/// n5, n6, n7 of one group at maximum compression in one figure.
fn n567(runs: &[Run], group: &str, out: &Path, file: &str) -> magopt::Result<()> {
    let of: Vec<Run> = runs
        .iter()
        .filter(|r| r.group == group)
        .map(|r| Run {
            group: String::new(),
            r: r.r,
            seed: r.seed,
            metric: r.metric.clone(),
        })
        .collect();
    let mut all = Vec::new();
    for name in ["n5_max", "n6_max", "n7_max"] {
        all.extend(curve_series(&curves(&of, &metric(name)), &name[..2]));
    }
    let fig = figure(
        &format!("n5, n6, n7 at maximum compression ({group})"),
        "fraction of counted cells",
        all,
    );
    render_png(&out.join(file), &fig)
}

/// Ψ6 versus n6 over all runs, per stage, with the Pearson coefficient (pooled and per group).
fn correlation(
    runs: &[Run],
    out: &Path,
    summary: &mut serde_json::Map<String, Value>,
) -> magopt::Result<()> {
    let mut plotted = Vec::new();
    let mut r_json = serde_json::Map::new();
    for stage in ["start", "max", "end"] {
        let (n6, psi6) = (format!("n6_{stage}"), format!("psi6_{stage}"));
        let pairs = |filter: &dyn Fn(&Run) -> bool| -> (Vec<f64>, Vec<f64>) {
            runs.iter()
                .filter(|r| filter(r))
                .filter_map(|r| Some((*r.metric.get(&n6)?, *r.metric.get(&psi6)?)))
                .unzip()
        };
        let (x, y) = pairs(&|_| true);
        let pooled = pearson(&x, &y).unwrap_or(f64::NAN);
        let mut groups = serde_json::Map::new();
        let names: std::collections::BTreeSet<&str> =
            runs.iter().map(|r| r.group.as_str()).collect();
        for g in names {
            let (gx, gy) = pairs(&|r| r.group == g);
            groups.insert(g.into(), json!(pearson(&gx, &gy).ok()));
        }
        r_json.insert(
            stage.into(),
            json!({"pooled": pooled, "runs": x.len(), "per_group": groups}),
        );
        plotted.push(series(
            &format!("{stage}: Pearson r = {pooled:.3} ({} runs)", x.len()),
            x,
            y,
            None,
            SeriesStyle::Points,
        ));
    }
    let fig = Figure {
        title: "Ψ6 versus n6 (every run of the bi-disperse studies)".into(),
        x_label: "n6".into(),
        y_label: "Ψ6".into(),
        series: plotted,
        ..Figure::default()
    };
    render_png(&out.join("psi6_vs_n6.png"), &fig)?;
    summary.insert("pearson_psi6_n6".into(), r_json.into());
    Ok(())
}

/// Per-species PDFs of F/F̄_s at maximum compression, pooled over seeds, one curve per
/// (configuration, species); Knuth bins.
fn force_histograms(
    configs: &[(String, f64, f64)],
    base: &BedParams,
    seeds: u64,
    file: &Path,
    title: &str,
) -> magopt::Result<Value> {
    let mut plotted = Vec::new();
    let mut info = serde_json::Map::new();
    for (label, r, a) in configs {
        let mut p = base.clone();
        (p.mixing_ratio, p.aspect_ratio) = (*r, *a);
        let (mut forces, mut species) = (Vec::new(), Vec::new());
        for seed in 1..=seeds {
            let o = run_cycle(&p, seed, &|_| {});
            let Some(s) = o.snapshots.iter().find(|s| s.label == "max-compression") else {
                eprintln!("{label} seed {seed}: {:?}", o.failure);
                continue;
            };
            let sp: Vec<i64> = s.species.iter().map(|&k| k as i64).collect();
            let force = s.force_magnitude();
            for d in force_distributions(&force, &sp)? {
                for (f, k) in force.iter().zip(&sp).filter(|(_, k)| **k == d.species) {
                    forces.push(f / d.mean);
                    species.push(*k);
                }
            }
        }
        for d in force_distributions(&forces, &species)? {
            let name = if d.species == 0 { "big" } else { "small" };
            let h = &d.histogram;
            let centres = h.edges.windows(2).map(|e| 0.5 * (e[0] + e[1])).collect();
            plotted.push(series(
                &format!(
                    "{label}, {name} ({} discs, {} bins)",
                    d.count,
                    h.counts.len()
                ),
                centres,
                h.density.clone(),
                None,
                SeriesStyle::LinePoints,
            ));
            let (_, std) = mean_std(
                &forces
                    .iter()
                    .zip(&species)
                    .filter(|(_, k)| **k == d.species)
                    .map(|(f, _)| *f)
                    .collect::<Vec<_>>(),
            );
            info.insert(
                format!("{label}, {name}"),
                json!({"discs": d.count, "bins": h.counts.len(), "relative_std": std}),
            );
        }
    }
    let fig = Figure {
        title: title.into(),
        x_label: "F / F̄_s (force over its species mean, at maximum compression)".into(),
        y_label: "probability density".into(),
        series: plotted,
        ..Figure::default()
    };
    render_png(file, &fig)?;
    Ok(info.into())
}

fn main() -> magopt::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = PathBuf::from(
        args.first()
            .map_or("results/structure/quick", String::as_str),
    );
    let arg = |k: usize, default: f64| args.get(k).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (particles, speed, seeds) = (
        arg(1, 100.0) as usize,
        arg(2, 22.5) * 1e-3,
        arg(3, 3.0) as u64,
    );
    let mut summary = serde_json::Map::new();
    let by_a = |t: &Table, i: usize| format!("a = {}", numbers(t, "aspect_ratio")[i]);
    let mut bi = load(&dir, "structure-bidisperse", &by_a);
    bi.extend(load(&dir, "structure-bidisperse-8mm", &|_, _| {
        "a = 0.75, D1 = 8 mm".into()
    }));
    force_ratio(&bi, &dir, &mut summary)?;
    metric_figures(&bi, &dir, "bidisperse", &mut summary)?;
    for (g, file) in [
        ("a = 0.5", "n567_vs_R_a0.5.png"),
        ("a = 0.75", "n567_vs_R_a0.75.png"),
    ] {
        n567(&bi, g, &dir, file)?;
    }
    correlation(&bi, &dir, &mut summary)?;
    let variant = |t: &Table, i: usize| {
        let g = numbers(t, "gravity_m_per_s2")[i];
        format!(
            "{}{}",
            texts(t, "friction")[i],
            if g == 0.0 { ", no gravity" } else { "" }
        )
    };
    let friction = load(&dir, "structure-friction", &variant);
    if !friction.is_empty() {
        metric_figures(&friction, &dir, "friction", &mut summary)?;
    }
    let mut base = BedParams::defaults();
    base.preset = Preset::Bidisperse;
    (base.particles, base.piston_speed) = (Some(particles), speed);
    let per_r: Vec<_> = [0.0, 0.5, 1.0]
        .iter()
        .map(|&r| (format!("R = {r}"), r, 0.5))
        .collect();
    let per_a: Vec<_> = [0.5, 0.6, 0.75]
        .iter()
        .map(|&a| (format!("a = {a}"), 0.5, a))
        .collect();
    let title = |what: &str| {
        format!("per-particle force PDFs {what} (N = {particles}, {seeds} seeds pooled)")
    };
    summary.insert(
        "force_histograms_per_R".into(),
        force_histograms(
            &per_r,
            &base,
            seeds,
            &dir.join("force_histograms_per_R.png"),
            &title("per R, a = 0.5"),
        )?,
    );
    summary.insert(
        "force_histograms_per_a".into(),
        force_histograms(
            &per_a,
            &base,
            seeds,
            &dir.join("force_histograms_per_a.png"),
            &title("per a, R = 0.5"),
        )?,
    );
    write_json_atomic(&dir.join("summary.json"), &summary.into())?;
    println!("figures and summary.json in {}", dir.display());
    Ok(())
}
