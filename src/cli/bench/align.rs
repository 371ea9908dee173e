//! `magopt bench align`: one full DEM run (settling, then alignment to the target) per particle
//! count and thread count: settling time, particle-steps per second of both stages, peak memory.
//! For the settling (packing stages 1–3, FIRE with harmonic then Hertz contacts, frictionless)
//! each row gives `settle_contacts_per_particle`, the evaluation-mean number of touching
//! partners per particle, `settle_list_entries_per_particle`, the partners checked (list skin
//! included; each pair from both sides, the lists being full), and
//! `settle_contact_evaluations_per_s`, touching pairs evaluated per second counted once each
//! (the count LAMMPS with Newton's third law on evaluates, bench/lammps/align-hertz.sh), also
//! per CPU second (per core on a loaded machine); `settle_stage_s` and `settle_list_builds`,
//! each stage's wall time and neighbour-list builds; `release_newton`, where the release
//! takes Newton steps (from `large_bed_from` particles on), its Newton steps, linear
//! iterations, local corrections and their visits, and the wall time of storing the
//! stiffnesses, of the solves and of the corrections. `loaded_contacts_per_particle` and
//! `released_contacts_per_particle` (printed as `z_rel`) are the particle contacts per particle
//! at the end of settling (the settling force on) and of the relaxation (the packing the
//! alignment starts from): whether the released bed kept its contact network
//! (results/bench/README.md, "The released bed").

use serde_json::json;
use std::time::Instant;

use super::{counts, cpu_seconds, heap, peak_rss_mb, pool, reset_peak_rss, run_on, BenchArgs};
use crate::materials::MaterialDb;
use crate::models::align::dem::{self, ContactWork, Packing};
use crate::models::align::AlignParams;
use crate::units::si_per_unit;
use crate::{Error, Result};

/// The align model: for each (N, threads) a settled packing (seed 1), then the alignment stage
/// (on `--tiles` K × K copies of the packing, if asked).
/// Threads act inside the run: the packing's force loop and, from `parallel_from` particles on,
/// the coloured Gauss–Seidel sweep. (Sweeps and optimizations parallelize across replicates.)
pub(super) fn run(db: &MaterialDb, args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
    let sizes = counts("particles", args.particles.as_deref(), &[1000, 10000])?;
    let threads = counts("threads", Some(&args.threads), &[])?;
    let material = db.get("srfe12o19")?.clone();
    println!(
        "align: Sr ferrite, 40 kOe, μ = 0.2, P = 0.5 atm, target A = 0.95, rest criterion {:?}, \
         release {:?}",
        args.rest, args.release
    );
    if args.tiles > 1 {
        println!(
            "tiled: a die of ⌈N/{0}⌉ particles settled (settling columns), {1} × {1} copies of it \
             aligned (N and the rest)",
            args.tiles * args.tiles,
            args.tiles
        );
    }
    println!(
        "{:>7} {:>3} {:>9} {:>8} {:>11} {:>9} {:>10} {:>5} {:>6} {:>7} {:>9} {:>10} {:>8} {:>7} {:>7}",
        "N",
        "thr",
        "settle s",
        "steps",
        "p-steps/s",
        "contacts",
        "contacts/s",
        "z_rel",
        "steps",
        "sweeps",
        "align s",
        "p-steps/s",
        "A_final",
        "MB",
        "heap MB"
    );
    let mut rows = Vec::new();
    for &n in &sizes {
        for &t in &threads {
            let pool = pool(t)?;
            let mut params =
                AlignParams::paper_defaults(material.clone(), 40.0 * si_per_unit("kOe"));
            let tiles = args.tiles as usize;
            params.particles = n.div_ceil(tiles * tiles);
            params.numerics.rest_measure = args.rest;
            params.numerics.release_scheme = args.release;
            reset_peak_rss();
            let (started, cpu_start) = (Instant::now(), cpu_seconds());
            let (packing, work) = run_on(&pool, || Packing::generate_counted(&params.packing(), 1))
                .map_err(Error::Output)?;
            let settle_s = started.elapsed().as_secs_f64();
            let packing_heap_mb = heap::peak_mb();
            heap::reset_peak();
            let settle_cpu_s = cpu_seconds() - cpu_start;
            let die = params.particles;
            let packing = packing.tiled(tiles);
            let n = packing.radius.len();
            params.particles = n;
            let all = Totals::of(&work, die);
            let (contacts_per_particle, contact_evaluations) =
                (all.contacts_per_particle, all.contact_evaluations);
            let [_, loaded, released] = work.map(|w| w.final_contacts as f64 / die as f64);
            let fire = fire_stages(&work[..2], &packing.steps[..2], die);
            let settle_steps: usize = packing.steps.iter().sum();
            params.max_time = (args.max_steps as f64 - 0.5) * dem::time_step_s(&params, &packing);
            let outcome = run_on(&pool, || dem::align(&params, &packing, None));
            let settle_rate = (settle_steps * die) as f64 / settle_s;
            let align_rate = (outcome.steps * n) as f64 / outcome.wall_time_s;
            let (peak_mb, alignment_heap_mb) = (peak_rss_mb(), heap::peak_mb());
            let heap_mb = packing_heap_mb.max(alignment_heap_mb);
            println!(
                "{n:>7} {t:>3} {settle_s:>9.1} {settle_steps:>8} {settle_rate:>11.3e} {contacts_per_particle:>9.2} {:>10.3e} {released:>5.2} {:>6} {:>7} {:>9.2} {align_rate:>10.3e} {:>8.4} {peak_mb:>7.1} {heap_mb:>7.1}",
                contact_evaluations / settle_s,
                outcome.steps,
                outcome.solver_sweeps,
                outcome.wall_time_s,
                outcome.final_alignment,
            );
            rows.push(json!({
                "particles": n,
                "threads": t,
                "tiles": tiles,
                "settled_particles": die,
                "rest_measure": args.rest,
                "release_scheme": args.release,
                "settle_s": settle_s,
                "settle_steps": packing.steps,
                "settle_particle_steps_per_s": settle_rate,
                "settle_cpu_s": settle_cpu_s,
                "settle_particle_steps_per_cpu_s": (settle_steps * die) as f64 / settle_cpu_s,
                "settle_contacts_per_particle": contacts_per_particle,
                "settle_list_entries_per_particle": all.list_entries_per_particle,
                "settle_contact_evaluations_per_s": contact_evaluations / settle_s,
                "settle_contact_evaluations_per_cpu_s": contact_evaluations / settle_cpu_s,
                "settle_stage_s": work.map(|w| w.seconds),
                "settle_list_builds": work.map(|w| w.list_builds),
                "release_newton": work[2].newton,
                "fire_stages": fire,
                "loaded_contacts_per_particle": loaded,
                "released_contacts_per_particle": released,
                "align_steps": outcome.steps,
                "align_solver_sweeps": outcome.solver_sweeps,
                "align_s": outcome.wall_time_s,
                "align_particle_steps_per_s": align_rate,
                "alignment_time_s": outcome.alignment_time_s,
                "final_alignment": outcome.final_alignment,
                "packing_fraction": outcome.packing_fraction,
                "peak_rss_mb": peak_mb,
                "peak_heap_mb": heap_mb,
                "packing_peak_heap_mb": packing_heap_mb,
                "alignment_peak_heap_mb": alignment_heap_mb,
            }));
        }
    }
    Ok(rows)
}

/// Stages 1 and 2 of the packing (overlap removal and settling: FIRE steps, each one force
/// evaluation), the part of it a granular pour does (`bench/lammps/align-hertz.sh`): steps,
/// wall time, step-mean contacts and list entries per particle, and rates per wall second.
fn fire_stages(work: &[ContactWork], steps: &[usize], die: usize) -> serde_json::Value {
    let totals = Totals::of(work, die);
    let seconds: f64 = work.iter().map(|w| w.seconds).sum();
    let steps: usize = steps.iter().sum();
    json!({
        "steps": steps,
        "s": seconds,
        "contacts_per_particle": totals.contacts_per_particle,
        "list_entries_per_particle": totals.list_entries_per_particle,
        "particle_steps_per_s": (steps * die) as f64 / seconds,
        "contact_evaluations_per_s": totals.contact_evaluations / seconds,
    })
}

/// What some packing stages' contact sums add up to over a die of `die` particles.
struct Totals {
    /// Step-mean touching partners per particle.
    contacts_per_particle: f64,
    /// Step-mean list entries per particle.
    list_entries_per_particle: f64,
    /// Touching pairs evaluated, each once.
    contact_evaluations: f64,
}

impl Totals {
    fn of(work: &[ContactWork], die: usize) -> Self {
        let total = |f: fn(&ContactWork) -> u64| work.iter().map(f).sum::<u64>() as f64;
        let per_particle = |f| total(f) / (total(|w| w.evaluations) * die as f64);
        Self {
            contacts_per_particle: per_particle(|w| w.contacts),
            list_entries_per_particle: per_particle(|w| w.list_entries),
            contact_evaluations: 0.5 * total(|w| w.contacts),
        }
    }
}
