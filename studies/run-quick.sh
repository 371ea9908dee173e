#!/usr/bin/env bash
# Regenerates results/quick/: every quick study, its tables and its plots.
# Usage (from the repository root): bash studies/run-quick.sh
set -euo pipefail
cargo build --release --locked
bin=target/release/magopt
for study in studies/quick/align-tau-*.toml; do
  name=$(basename "$study" .toml)
  rm -rf "results/quick/$name"
  "$bin" sweep "$study" --out "results/quick/$name"
  "$bin" plot "results/quick/$name"
done
rm -rf results/quick/align-optimize-field
"$bin" optimize studies/quick/align-optimize-field.toml --out results/quick/align-optimize-field
# bed and damper quick studies (about a minute each on 2 cores) into results/bed/quick/
for study in studies/quick/bed-*.toml studies/quick/damper.toml; do
  name=$(basename "$study" .toml)
  rm -rf "results/bed/quick/$name"
  "$bin" sweep "$study" --out "results/bed/quick/$name"
  "$bin" plot "results/bed/quick/$name"
done
# structure studies (about a minute each) into results/structure/quick/, their figures and fits
# (examples/structure_figures.rs), and the damper with both fits of its second motion
for study in studies/quick/structure-*.toml; do
  name=$(basename "$study" .toml)
  rm -rf "results/structure/quick/$name"
  "$bin" sweep "$study" --out "results/structure/quick/$name"
  rm -rf "results/structure/quick/$name/runs"
done
cargo run --release --locked --example structure_figures -- results/structure/quick 100 22.5 3
rm -rf results/structure/quick/damper-fit
"$bin" damper --particles 92 --piston-mass 200g --tail-correction none --out results/structure/quick/damper-fit
rm -rf results/structure/quick/damper-fit/runs
