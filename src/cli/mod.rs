//! Command-line interface (spec studies.md, "Command line"). Parsing and printing only: every
//! computation is a library call. Errors are printed as one line and exit with code 2.

mod align;
mod analyze;
mod bed;
mod bench;
mod blast;
mod study;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

use crate::materials::MaterialDb;
use crate::{Error, Result};

/// magopt: simulation-based optimization of magnetic particle processes.
#[derive(Debug, Parser)]
#[command(name = "magopt", version, about, long_about = None)]
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
    /// One compression cycle of a bed of repelling magnets under a piston.
    Bed(bed::BedArgs),
    /// A free-falling piston onto a bed of repelling magnets (magnetic granular damper).
    Damper(bed::BedArgs),
    /// One blast run: a charged cloud in E and B fields with drag (and interactions).
    Blast(Box<blast::BlastArgs>),
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

/// Runs the CLI; returns the process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
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
            return 2;
        }
    };
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("magopt: {}", e.to_string().replace('\n', " "));
            2
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let mut db = MaterialDb::builtin();
    if let Some(path) = &cli.materials {
        db.load_file(path)?;
    }
    match cli.command {
        Command::Materials => {
            print!("{}", db.table());
            Ok(())
        }
        Command::Align(args) => align::run_align(&db, &args),
        Command::Blast(args) => blast::run_blast(&args),
        Command::OptimizeField(args) => align::run_optimize(&db, &args),
        Command::Bed(args) => bed::run(&args, false),
        Command::Damper(args) => bed::run(&args, true),
        Command::Sweep(args) => study::sweep(db, &args),
        Command::Optimize(args) => study::optimize(db, &args),
        Command::Collect(args) => study::collect(db, &args),
        Command::Plot(args) => study::plot(&args),
        Command::Bench(args) => bench::run(&db, &args),
        Command::Analyze(args) => analyze::run(&args),
    }
}

/// The command line as typed (provenance).
fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// Sizes the global thread pool (`--threads`); all cores by default.
fn threads(n: Option<usize>) -> Result<()> {
    if let Some(n) = n {
        if n == 0 {
            return Err(Error::input("--threads: 0 is not allowed (need ≥ 1)"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .ok();
    }
    Ok(())
}

/// A count ≥ 1, from text so that negative values get our message rather than a parse error.
fn count(option: &str, text: &str) -> Result<usize> {
    match text.trim().parse::<i64>() {
        Ok(n) if n >= 1 => Ok(n as usize),
        Ok(n) => Err(Error::input(format!(
            "--{option}: {n} is not allowed (need a whole number ≥ 1)"
        ))),
        Err(_) => Err(Error::input(format!(
            "--{option}: '{text}' is not a whole number (need ≥ 1)"
        ))),
    }
}
