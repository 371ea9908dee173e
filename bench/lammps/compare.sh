#!/usr/bin/env bash
# magopt's kernels side by side with LAMMPS, one core each: the blast near field (all pairs),
# the bed's r⁻⁴ pairs (cut-off and Verlet list) and the align settling (Hertz contacts). Runs
# the three scripts beside this one, then prints one table of the ratios magopt / LAMMPS per
# CPU second (per core; each script also prints the wall-clock figures and what was matched).
# Takes about 10 CPU minutes. Exits 0 with a note where `lmp` is not installed.
# Usage: bash bench/lammps/compare.sh [magopt binary]
set -euo pipefail
here=$(dirname "$0")
source "$here/lib.sh"
prepare "$@"
echo "start: $(machine)"
for script in blast-near-field bed-pairs align-hertz; do
  bash "$here/$script.sh" "$bin" | tee "$work/$script.out"
  echo
done
echo "end: $(machine)"
echo "magopt / LAMMPS, 1 core each, per CPU second (> 1: magopt faster)"
printf '%-30s %16s %18s\n' kernel particle-steps "pair evaluations"
cat "$work"/{blast-near-field,bed-pairs,align-hertz}.out | awk -F'|' '$1 == "summary" {printf "%-30s %16s %18s\n", $2, $3, $4}'
