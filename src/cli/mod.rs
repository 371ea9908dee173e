//! Command-line interface (spec studies.md, "Command line"). Parsing and printing only: every
//! computation is a library call. Errors are printed as one line.
//!
//! Exit codes: 0 success (a sweep whose runs failed still succeeds: failures are data);
//! 2 bad input (options, study and input files, an unwritable output); 3 a single run
//! (`align`, `bed`, `damper`, `blast`) failed or did not reach its target (its summary or JSON
//! is still printed); 4 `collect` found runs missing (unless `--allow-partial`).

mod align;
mod align_diagnostics;
mod analyze;
mod bed;
mod bench;
mod blast;
mod heap;
mod params;
mod progress;
mod run;
mod study;

use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, Subcommand};
use std::path::PathBuf;

use crate::materials::MaterialDb;
use crate::models::align::study::AlignModel;
use crate::models::bed::study::BedModel;
use crate::models::blast::study::BlastModel;
use crate::{Error, Result};

pub use heap::CountingAllocator;

/// Exit code of bad input.
pub const EXIT_INPUT: i32 = 2;
/// Exit code of a single run that failed or did not reach its target.
pub const EXIT_RUN_UNSUCCESSFUL: i32 = 3;
/// Exit code of `collect` when runs of the study are missing.
pub const EXIT_INCOMPLETE: i32 = 4;

const EXIT_CODES: &str = "Exit codes: 0 success (failed runs of a sweep are recorded as data); \
2 bad input; 3 a single run failed or did not reach its target (its output is still printed); \
4 collect found runs missing (see --allow-partial).";

/// magopt: simulation-based optimization of magnetic particle processes.
#[derive(Debug, Parser)]
#[command(name = "magopt", version, about, long_about = None, after_help = EXIT_CODES)]
pub struct Cli {
    /// Extra or overriding materials from a TOML file ([[material]] tables with name,
    /// saturation_magnetization, anisotropy_constant, youngs_modulus, poisson_ratio, density;
    /// values with units, e.g. "380 emu/cm3").
    #[arg(long, global = true, value_name = "FILE")]
    materials: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List the built-in (and --materials) materials with H_K and β.
    Materials,
    /// One alignment run: settle a powder, switch on field and pressure, report τ.
    Align(align::AlignArgs),
    /// Find the field that aligns the powder fastest (the headline study).
    OptimizeField(align::OptimizeArgs),
    /// The source's single-particle figures for a material: ψ(θ), torque vs H, field of maximum
    /// torque vs θ (Parquet tables and PNGs).
    AlignDiagnostics(align_diagnostics::DiagnosticsArgs),
    /// One compression cycle of a bed of repelling magnets under a piston.
    Bed(bed::BedArgs),
    /// A free-falling piston onto a bed of repelling magnets (magnetic granular damper).
    Damper(bed::BedArgs),
    /// One blast run: a charged cloud in E and B fields with drag (and interactions).
    Blast(blast::BlastArgs),
    /// Structure, order and force analysis of a 2D snapshot (Parquet or CSV).
    Analyze(analyze::AnalyzeArgs),
    /// Run a study file's grid × replicates in parallel; tables and provenance into --out.
    Sweep(study::SweepArgs),
    /// Optimize the free parameter(s) of a study file's [optimize] table.
    Optimize(study::OptimizeArgs),
    /// Merge the result directories of shards of one study into one result.
    Collect(study::CollectArgs),
    /// Render the standard figures of a study result directory into DIR/plots/.
    Plot(study::PlotArgs),
    /// Benchmarks of a model (align, bed, blast, analyze): throughput and peak memory.
    Bench(bench::BenchArgs),
}

/// The command line: the derived commands plus one flag per model parameter, made from the
/// parameter declarations (defaults from the built-in materials).
pub fn command() -> clap::Command {
    let align = AlignModel::new(MaterialDb::builtin());
    Cli::command()
        .mut_subcommand("align", |c| c.args(params::flags(&align, &[])))
        .mut_subcommand("optimize-field", |c| {
            c.args(params::flags(&align, &["field"]))
        })
        .mut_subcommand("bed", |c| c.args(params::flags(&BedModel::cycle(), &[])))
        .mut_subcommand("damper", |c| {
            c.args(params::flags(&BedModel::damper(), &[]))
        })
        .mut_subcommand("blast", |c| c.args(params::flags(&BlastModel, &[])))
}

/// Runs the CLI; returns the process exit code.
pub fn main() -> i32 {
    let parsed = command()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m).map(|cli| (cli, m)));
    let (cli, matches) = match parsed {
        Ok(parsed) => parsed,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = e.print();
                return 0;
            }
            let text = e.to_string();
            let line = text
                .lines()
                .next()
                .unwrap_or("invalid arguments")
                .trim_start_matches("error: ");
            eprintln!("magopt: {line}");
            return EXIT_INPUT;
        }
    };
    let sub = matches
        .subcommand()
        .map(|(_, m)| m.clone())
        .unwrap_or_default();
    match run(cli, &sub) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("magopt: {}", e.to_string().replace('\n', " "));
            EXIT_INPUT
        }
    }
}

fn run(cli: Cli, matches: &ArgMatches) -> Result<i32> {
    let mut db = MaterialDb::builtin();
    if let Some(path) = &cli.materials {
        db.load_file(path)?;
    }
    match cli.command {
        Command::Materials => {
            print!("{}", db.table());
            Ok(0)
        }
        Command::Align(args) => align::run_align(&db, matches, &args),
        Command::Blast(args) => blast::run_blast(matches, &args),
        Command::OptimizeField(args) => align::run_optimize(&db, matches, &args),
        Command::AlignDiagnostics(args) => align_diagnostics::run(&db, &args),
        Command::Bed(args) => bed::run(matches, &args, false),
        Command::Damper(args) => bed::run(matches, &args, true),
        Command::Sweep(args) => study::sweep(db, &args),
        Command::Optimize(args) => study::optimize(db, &args),
        Command::Collect(args) => study::collect(db, &args),
        Command::Plot(args) => study::plot(&args),
        Command::Bench(args) => bench::run(&db, &args).map(|()| 0),
        Command::Analyze(args) => analyze::run(&args).map(|()| 0),
    }
}

/// The command line as typed (provenance).
fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// Sizes the global thread pool (`--threads`); all cores by default.
fn threads(n: Option<usize>) -> Result<()> {
    if let Some(n) = n {
        if !(1..=MAX_THREADS).contains(&n) {
            return Err(Error::input(format!(
                "--threads: {n} is not allowed (need 1..={MAX_THREADS})"
            )));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .ok();
    }
    Ok(())
}

/// Most worker threads --threads takes (each has its own stack: a million would never start).
const MAX_THREADS: usize = 1024;

/// Largest count an option such as --replicates or --scan-points takes.
const MAX_OPTION_COUNT: i64 = 1_000_000;

/// A count in 1..=[`MAX_OPTION_COUNT`], from text so that negative values get our message
/// rather than a parse error.
fn count(option: &str, text: &str) -> Result<usize> {
    match text.trim().parse::<i64>() {
        Ok(n) if (1..=MAX_OPTION_COUNT).contains(&n) => Ok(n as usize),
        Ok(n) => Err(Error::input(format!(
            "--{option}: {n} is not allowed (need a whole number in 1..={MAX_OPTION_COUNT})"
        ))),
        Err(_) => Err(Error::input(format!(
            "--{option}: '{text}' is not a whole number (need 1..={MAX_OPTION_COUNT})"
        ))),
    }
}
