#!/usr/bin/env bash
# The default tail on bi-disperse beds against exact sums and the truncated list (results/bed/README.md,
# "Tail correction over whole cycles"); run from this folder. MAGOPT: the binary (default ../../../../target/release/magopt).
B=${MAGOPT:-../../../../target/release/magopt}
# the time-step factor these runs were made with (the default since 2026-12-05 is 0.4 with dry friction)
step="--time-step-factor 0.2"
# run NAME ARGS...: exact sums, the default (tail) and the truncated list of one bed
run() {
  local c=$1; shift
  $B bed $step "$@" --neighbors exact --json > exact-$c.json
  $B bed $step "$@" --json > tail-$c.json
  $B bed $step "$@" --tail-correction none --json > list-$c.json
}
# quick size: N = 100 (the preset scaled by sqrt(1/4)), 22.5 mm/s
for a in 0.5 0.75; do for r in 0.5 1; do for s in 1 2 3; do
  run a$a-R$r-s$s --preset bidisperse --particles 100 --aspect-ratio $a --mixing-ratio $r --piston-speed 22.5mm/s --seed $s
done; done; done
# the preset's own size, N = 400, a = 0.5, 22.5 mm/s (R = 0 with 8 seeds)
for s in 1 2 3 4 5 6 7 8; do
  run n400-a0.5-R0-s$s --preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0 --piston-speed 22.5mm/s --seed $s
done
for s in 1 2 3; do
  run n400-a0.5-R0.5-s$s --preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0.5 --piston-speed 22.5mm/s --seed $s
done
# the F_max offset at N = 400, R = 0: other approximations and a perturbation of exact sums
for s in 1 2 3 4 5 6 7 8; do
  f=(--preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0 --piston-speed 22.5mm/s --seed $s)
  $B bed $step "${f[@]}" --neighbors tree --opening-angle 0.3 --json > tree0.3-n400-a0.5-R0-s$s.json
  $B bed "${f[@]}" --neighbors exact --time-step-factor 0.2001 --json > exact-dt0.2001-n400-a0.5-R0-s$s.json
  [ $s -le 4 ] && $B bed $step "${f[@]}" --neighbors tree --opening-angle 0.1 --json > tree0.1-n400-a0.5-R0-s$s.json
done
# a list whose cut-off spans the cell: exact sums' answer (seed 1)
$B bed $step --preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0 --piston-speed 22.5mm/s --seed 1 \
  --neighbors verlet --cutoff 500 --list-radius 501 --tail-correction none --json > list-cutoff500-n400-a0.5-R0-s1.json
# (2026-12-04) the same beds from nearby starts: initial velocities scaled by 1.01, 0.99, 1.02, 0.98
# (exact sums, the default tail and the quadtree at 0.3), and the quadtree at 0.02 on seed 2
for v in 0.0101 0.0099 0.0102 0.0098; do for s in 1 2 3 4 5 6 7 8; do
  f=(--preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0 --piston-speed 22.5mm/s --seed $s --initial-speed $v)
  $B bed $step "${f[@]}" --neighbors exact --json > exact-v$v-n400-a0.5-R0-s$s.json
  $B bed $step "${f[@]}" --json > tail-v$v-n400-a0.5-R0-s$s.json
  $B bed $step "${f[@]}" --neighbors tree --opening-angle 0.3 --json > tree0.3-v$v-n400-a0.5-R0-s$s.json
done; done
$B bed $step --preset bidisperse --particles 400 --aspect-ratio 0.5 --mixing-ratio 0 --piston-speed 22.5mm/s --seed 2 \
  --neighbors tree --opening-angle 0.02 --json > tree0.02-n400-a0.5-R0-s2.json
