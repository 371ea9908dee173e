# The tail-correction runs of results/bed/README.md, "Tail correction over whole cycles" (run from this folder).
# uniform/ holds the same runs of the first, uniform-density tail (2026-12-03), made by this script at that commit.
B=${MAGOPT:-../../../target/release/magopt}
# the time-step factor these runs were made with (the default since 2026-12-05 is 0.4 with dry friction)
step="--time-step-factor 0.2"
for n in 368 736 1472 2208 4416 10000; do
  $B bed $step --particles $n --piston-speed 128mm/s --tail-correction mean-field --json > fast-N$n.json
done
for s in 1 2 3; do
  $B bed $step --particles 736 --piston-speed 8.33mm/s --seed $s --tail-correction mean-field --json > mid-N736-s$s.json
done
$B bed $step --particles 368 --tail-correction mean-field --json > std-N368.json
# references at N = 4416 (the exact sums take about 18 minutes on 2 cores) and the list alone at 10^4
$B bed $step --particles 4416 --piston-speed 128mm/s --neighbors exact --json > exact-fast-N4416.json
$B bed $step --particles 4416 --piston-speed 128mm/s --tail-correction none --json > list-fast-N4416.json
$B bed $step --particles 10000 --piston-speed 128mm/s --tail-correction none --json > list-fast-N10000.json
# five seeds at the default speed, N = 368 (seed 1: std-N368.json and results/bench/README.md, "Bed far field")
mkdir -p std-seeds
for s in 2 3 4 5; do
  $B bed $step --particles 368 --seed $s --neighbors exact --json > std-seeds/exact-s$s.json
  $B bed $step --particles 368 --seed $s --tail-correction mean-field --json > std-seeds/tail-s$s.json
  $B bed $step --particles 368 --seed $s --tail-correction none --json > std-seeds/list-s$s.json
done
# the reference at N = 10^4 (no exact run: hours): the quadtree, every pair every step, theta 0.3 (33.5 min on 2 cores)
mkdir -p tree
$B bed $step --particles 10000 --piston-speed 128mm/s --neighbors tree --opening-angle 0.3 --json > tree/tree0.3-fast-N10000.json
# the damper (N = 368, 200 g piston, seed 1) with exact sums, the default tail and the truncated list
mkdir -p damper
$B damper --particles 368 --piston-mass 200g --neighbors exact --json --out /tmp/damper-exact > damper/exact.json
$B damper --particles 368 --piston-mass 200g --json --out /tmp/damper-tail > damper/tail.json
$B damper --particles 368 --piston-mass 200g --tail-correction none --json --out /tmp/damper-list > damper/list.json
