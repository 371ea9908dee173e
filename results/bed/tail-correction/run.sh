# The tail-correction runs of results/bed/README.md, "Tail correction over whole cycles" (run from this folder).
B=${MAGOPT:-../../../target/release/magopt}
for n in 368 736 1472 2208; do
  $B bed --particles $n --piston-speed 128mm/s --tail-correction mean-field --json > fast-N$n.json
done
for s in 1 2 3; do
  $B bed --particles 736 --piston-speed 8.33mm/s --seed $s --tail-correction mean-field --json > mid-N736-s$s.json
done
$B bed --particles 368 --tail-correction mean-field --json > std-N368.json
