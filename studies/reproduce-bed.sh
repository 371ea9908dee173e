#!/usr/bin/env bash
# The bed and damper models against de Paula 2025 (docs/bed.md, docs/bed-protocol.md), table by
# table on the source's own protocol: runs every case of results/reproduction/bed.md and renders
# the report (studies/report-bed.sh).
# Usage (from the repository root):
#   bash studies/reproduce-bed.sh          # full: the source's sizes, seeds and speeds (hours)
#   bash studies/reproduce-bed.sh --quick  # CI size: N = 92…184, two seeds, N = 100 bi-disperse
# Runs land in results/reproduction/bed-runs[-quick]/<case>.json (the `magopt bed --json` or
# `magopt damper --json` record of each run); the report goes to
# results/reproduction/bed[-quick].md. A case whose record exists is not run again (delete the
# directory for a fresh run), so an interrupted full run resumes; the report marks cases not
# run. The cases run in order of priority: the speed, damper and friction cases, Tables 3.2/5.2 and 3.1,
# Fig. 5.2, the force maps, the bi-disperse beds, then the 10-seed sweep of Fig. 3.3a (its spread needs python3
# with pyarrow: scripts/force-spread.py).
set -euo pipefail
mode=${1:-full}
bin=${MAGOPT:-target/release/magopt}
[ -x "$bin" ] || cargo build --release --locked
if [ "$mode" = "--quick" ]; then
  suffix=-quick; n_std=92; table31="92 184"; table52="92 184"; seeds="1 2"
  radii="6.26 11.26"; n_bi=100; ratios_bi="1 0 0.5"; seeds_bi=1; seeds10=studies/quick/bed-initial-conditions.toml
else
  suffix=; n_std=368; table31="92 184 276 368 460 552 644 736"
  table52="368 460 552 644 736"; seeds="1 2 3"
  radii="6.26 7.26 8.26 9.26 10.26 11.26 12.26"; n_bi=400
  ratios_bi="1 0 0.5 0.2 0.8 0.9 0.7 0.3 0.1 0.6 0.4"; seeds_bi="1 2 3 4 5"; seeds10=studies/bed-initial-conditions.toml
fi
out=results/reproduction/bed-runs$suffix
mkdir -p "$out"
# run MODEL CASE ARGS…: one run's JSON record (exit 3, a failed run, is still a record)
run() {
  local model=$1 name=$2; shift 2
  [ -s "$out/$name.json" ] && return 0
  "$bin" "$model" --json "${step[@]}" "$@" > "$out/$name.part" || [ $? -eq 3 ]
  mv "$out/$name.part" "$out/$name.json"
}
# §3.5 and Table 3.1/3.2 speed (Figs. 3.9–3.12: "v = 8.33 mm/s")
std=(--piston-speed 8.33mm/s)
# the cases on magopt's own list: truncated at r_c, as the shipped reports were made (the
# default since 2026-12-04 adds the mean-field tail beyond r_c, docs/bed.md "Tail correction")
cut=(--tail-correction none)
# every run at the time-step factor the shipped runs were made with (the default since
# 2026-12-05 is 0.4 with dry friction, 0.2 without it and for the damper: docs/bed.md
# "Integration")
step=(--time-step-factor 0.2)

# the default cycle with lists (speed line of the issue) and the damper (§5.3, Fig. 5.12)
run bed default-N$n_std --particles $n_std "${cut[@]}"
run damper damper-N$n_std --particles $n_std "${cut[@]}" --out "$out/damper-N$n_std"
# §3.4, Figs. 3.5–3.7: the second-order tilt term (Eq. (3.2)), with the standard friction
# coefficients and with μ_s = μ_d = 0.8, against the first-order default-N… above (5.63 mm/s)
run bed tilt2-N$n_std --particles $n_std --tilt-order second "${cut[@]}"
run bed tilt2-mu0.8-N$n_std --particles $n_std --tilt-order second --static-friction 0.8 \
  --dynamic-friction 0.8 "${cut[@]}"
# Tables 3.2 and 5.2: exact sums ("standard", O(N²)) and the source's Verlet variant
# (every pair of the r_v = 11.26 D list, rebuilt after 4.13 D), seeds 1–3
for n in $table52; do
  for s in $seeds; do
    run bed exact-N$n-s$s --particles $n --seed $s --neighbors exact "${std[@]}"
    run bed sv11.26-N$n-s$s --particles $n --seed $s --neighbors source-verlet \
      --list-radius 11.26 --rebuild-skin 4.13 "${std[@]}"
  done
done
# Table 3.1: the same exact runs, seed 1, down to N = 92
for n in $table31; do
  run bed exact-N$n-s1 --particles $n --seed 1 --neighbors exact "${std[@]}"
done
# Fig. 5.2: force and run time against r_v (r_s = 4.13 D kept, as §5.1.1)
for r in $radii; do
  for s in $seeds; do
    run bed sv$r-N$n_std-s$s --particles $n_std --seed $s --neighbors source-verlet \
      --list-radius $r --rebuild-skin 4.13 "${std[@]}"
  done
done
# Table 5.1's slope: the same Verlet-variant cycles (seed 1) with the plates' dry friction
# replaced by the viscous law alone; F_max − F_max(viscous) is the dry friction's share
for n in $table52; do
  run bed svvisc-N$n-s1 --particles $n --seed 1 --neighbors source-verlet --list-radius 11.26 \
    --rebuild-skin 4.13 --friction-model viscous "${std[@]}"
done
# ... and with the plate gap E 0.01 mm below and above Table 2.1's 3.1 mm: the plates' normal
# force (B4) rests on θ = arcsin(E/√(D² + ε²)) − φ ≈ 0.96°, a small difference of two 27° angles
for n in $table52; do
  for gap in 3.09 3.11; do
    run bed svgap$gap-N$n-s1 --particles $n --seed 1 --neighbors source-verlet --list-radius 11.26 \
      --rebuild-skin 4.13 --gap ${gap}mm "${std[@]}"
  done
done
# Figs. 4.23–4.24: magnetic force vectors and their fluctuations at maximum compression, the
# standard bi-disperse system (a = 0.6, dry friction) at R = 0.25, 0.5, 0.75 (magopt analyze on
# the run's snapshot: force_vectors.png, fluctuations.png and the force-chain measures)
for r in 0.25 0.5 0.75; do
  c=forces-a0.6-R$r
  run bed $c --preset bidisperse --particles $n_bi --aspect-ratio 0.6 --mixing-ratio $r \
    --piston-speed 1mm/s "${cut[@]}" --out "$out/$c"
  [ -s "$out/$c-analysis.json" ] || { "$bin" analyze "$out/$c/snapshots/max-compression.parquet" \
    --out "$out/$c/analysis" --json > "$out/$c-analysis.part" && mv "$out/$c-analysis.part" \
    "$out/$c-analysis.json"; }
  rm -rf "$out/$c/runs" # the run's record (megabytes); $c.json and the tables hold the data
done
# Part II: bi-disperse beds at Table A.1's heights (H0 = H, φ_max = 0.34: the bidisperse
# preset's source heights) and speed V_c = 1 mm/s; R = 0 is the a = 1 bed of Table 4.6. Seed 1
# of every case first, then the other seeds ratio by ratio in the order of $ratios_bi (R = 1, the
# ratios' denominator, first), so an interrupted run leaves whole seed sets for the first ratios
bi() { # bi SEED RATIO: the case at every a (R = 0 once: the same all-big bed for every a)
  local a
  for a in 0.5 0.6 0.75; do
    [ "$2" = 0 ] && [ "$a" != 0.6 ] && continue
    run bed bi-a$a-R$2-s$1 --preset bidisperse --particles $n_bi --aspect-ratio $a \
      --mixing-ratio $2 --piston-speed 1mm/s --seed $1 "${cut[@]}"
  done
}
for r in $ratios_bi; do bi 1 $r; done
for r in $ratios_bi; do
  for s in $seeds_bi; do [ "$s" = 1 ] || bi $s $r; done
done
# Fig. 3.3a inset: the force's spread over 10 seeds (5.63 mm/s), from the sweep's series
if [ ! -s "$out/initial-conditions/series.parquet" ]; then
  "$bin" sweep "$seeds10" --out "$out/initial-conditions" > /dev/null
  rm -rf "$out/initial-conditions/runs" # per-run records (megabytes); the tables hold the data
fi
python3 scripts/force-spread.py "$out/initial-conditions" > "$out/force-spread.json.part" &&
  mv "$out/force-spread.json.part" "$out/force-spread.json" ||
  echo "force spread not computed (scripts/force-spread.py needs python3 with pyarrow)" >&2
# keep the runs' figures and tables, and the snapshot at maximum compression (kilobytes: the
# force maps are analysed from it); the other particle files (megabytes) are not needed here
find "$out" -path '*/snapshots/*' -type f ! -name '*.png' ! -name max-compression.parquet -delete
bash studies/report-bed.sh "$out" > "results/reproduction/bed$suffix.md"
echo "wrote results/reproduction/bed$suffix.md"
