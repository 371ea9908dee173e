#!/usr/bin/env bash
# Regenerates results/blast/quick/: every quick blast study, its tables and its plots.
# Usage (from the repository root): bash studies/run-quick-blast.sh
set -euo pipefail
cargo build --release --locked
bin=target/release/magopt
out=results/blast/quick
for study in studies/quick/blast-field-on-off.toml studies/quick/blast-aspect-vs-field.toml \
             studies/quick/blast-interacting.toml; do
  name=$(basename "$study" .toml)
  rm -rf "$out/$name"
  "$bin" sweep "$study" --out "$out/$name"
  "$bin" plot "$out/$name"
done
rm -rf "$out/blast-optimize-field"
"$bin" optimize studies/quick/blast-optimize-field.toml --out "$out/blast-optimize-field"
