#!/usr/bin/env bash
# Regenerates results/blast/quick/: every quick blast study, its tables and its plots.
# Usage (from the repository root): bash studies/run-quick-blast.sh
set -euo pipefail
cargo build --release --locked
bin=target/release/magopt
out=results/blast/quick
for study in studies/quick/blast-field-on-off.toml studies/quick/blast-aspect-vs-field.toml \
             studies/quick/blast-interacting.toml studies/quick/blast-near-field-strength.toml; do
  name=$(basename "$study" .toml)
  rm -rf "$out/$name"
  "$bin" sweep "$study" --out "$out/$name"
  "$bin" plot "$out/$name"
done
rm -rf "$out/blast-optimize-field"
"$bin" optimize studies/quick/blast-optimize-field.toml --out "$out/blast-optimize-field"
# Snapshots (extended XYZ, Parquet, side views) of single runs: field on, and the interacting
# example with the near field.
rm -rf "$out/run-field-on" "$out/run-near-field"
"$bin" blast --particles 500 --energy 2.5kJ --out "$out/run-field-on" --snapshot-times 0,0.25,0.5,1
"$bin" blast --interacting --particles 300 --energy 1.5kJ --out "$out/run-near-field" \
  --snapshot-times 0,0.02,0.05,0.2,1
