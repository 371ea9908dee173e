#!/usr/bin/env bash
# What the bed's speed settings cost against exact sums, seed by seed (results/bed/README.md,
# "Speed settings against exact sums"; 2026-12-05). Run from this folder; MAGOPT: the binary
# (default ../../../target/release/magopt). Writes one JSON per run into json/ (not kept in
# the repository: about 3 MB) and then runs.csv (summarize.py).
# Each setting is named by its label; c<r_c>: the cut-off in D_1 with the default tail and a
# skin of 0.87 D_1, k<K>: far-field interval K (then s<r_s>: its near cut-off in D_1, 45 for
# 4.5), f<x>: time-step factor 0.<x>, c2: a 2 ms cap.
# Every run gives its time-step factor and cap, so the script means the same at any default.
set -u
B=${MAGOPT:-../../../target/release/magopt}
mkdir -p json
run() { # FILE ARGS...
  local f=json/$1; shift
  [ -s "$f" ] || $B bed --json "$@" > "$f"
}
f2=(--time-step-factor 0.2 --max-time-step 1ms)
# 128 mm/s (the top of the source's speeds): every setting against exact sums
fast() { # N SEEDS...
  local n=$1; shift
  for s in "$@"; do
    local a=(--particles $n --piston-speed 128mm/s --seed $s)
    run fast-N$n-exact-s$s.json "${a[@]}" "${f2[@]}" --neighbors exact
    run fast-N$n-c713-s$s.json "${a[@]}" "${f2[@]}"
    run fast-N$n-c6-s$s.json "${a[@]}" "${f2[@]}" --cutoff 6 --list-radius 6.87
    run fast-N$n-c5-s$s.json "${a[@]}" "${f2[@]}" --cutoff 5 --list-radius 5.87
    run fast-N$n-c4-s$s.json "${a[@]}" "${f2[@]}" --cutoff 4 --list-radius 4.87
    run fast-N$n-c713f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms
    run fast-N$n-c713f4c2-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 2ms
    [ $n -le 736 ] && run fast-N$n-c713k4-s$s.json "${a[@]}" "${f2[@]}" --far-field-interval 4
    # 2026-12-06, third session: the interval and the near cut-off r_s (in D_1) of the holding
    if [ $n -le 736 ]; then
      run fast-N$n-c713k2-s$s.json "${a[@]}" "${f2[@]}" --far-field-interval 2
      run fast-N$n-c713k8-s$s.json "${a[@]}" "${f2[@]}" --far-field-interval 8
      for rs in 2 4.5 6; do
        run fast-N$n-c713k4s${rs/./}-s$s.json "${a[@]}" "${f2[@]}" --far-field-interval 4 --near-cutoff $rs
      done
    fi
    run fast-N$n-c5f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms --cutoff 5 --list-radius 5.87
    run fast-N$n-c5k4f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms --cutoff 5 --list-radius 5.87 \
      --far-field-interval 4
    run fast-N$n-list-s$s.json "${a[@]}" "${f2[@]}" --tail-correction none
  done
}
fast 368 $(seq 1 24)
fast 736 $(seq 1 16)
fast 1472 $(seq 1 12)
# the standard speed (5.63 mm/s), one thread per run
std() { # N SEEDS...
  local n=$1; shift
  for s in "$@"; do
    local a=(--particles $n --seed $s)
    [ $n -le 368 ] && {
      run std-N$n-exact-s$s.json "${a[@]}" "${f2[@]}" --neighbors exact
      run std-N$n-exactf4-s$s.json "${a[@]}" --neighbors exact --time-step-factor 0.4 --max-time-step 1ms
      run std-N$n-exactf8-s$s.json "${a[@]}" --neighbors exact --time-step-factor 0.8 --max-time-step 1ms
      run std-N$n-exactf4c2-s$s.json "${a[@]}" --neighbors exact --time-step-factor 0.4 --max-time-step 2ms
      run std-N$n-exactf8c2-s$s.json "${a[@]}" --neighbors exact --time-step-factor 0.8 --max-time-step 2ms
      run std-N$n-c6-s$s.json "${a[@]}" "${f2[@]}" --cutoff 6 --list-radius 6.87
      run std-N$n-c6f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms --cutoff 6 --list-radius 6.87
    }
    run std-N$n-c713-s$s.json "${a[@]}" "${f2[@]}"
    run std-N$n-c713f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms
    run std-N$n-c713f4c2-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 2ms
    run std-N$n-c713f8c2-s$s.json "${a[@]}" --time-step-factor 0.8 --max-time-step 2ms
  done
}
RAYON_NUM_THREADS=1 std 368 $(seq 1 12)
RAYON_NUM_THREADS=1 std 736 $(seq 1 8)
RAYON_NUM_THREADS=1 std 1472 $(seq 1 8)
# N = 4416, the standard speed: the 2 ms cap at factors 0.4 and 0.8 against the default (factor
# 0.4 under the 1 ms cap; 2026-12-05, sixth session)
for s in 1 2 3 4; do
  a=(--particles 4416 --seed $s)
  RAYON_NUM_THREADS=1 run std-N4416-c713f4-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 1ms
  RAYON_NUM_THREADS=1 run std-N4416-c713f4c2-s$s.json "${a[@]}" --time-step-factor 0.4 --max-time-step 2ms
  RAYON_NUM_THREADS=1 run std-N4416-c713f8c2-s$s.json "${a[@]}" --time-step-factor 0.8 --max-time-step 2ms
done
# without dry friction (none, viscous), N = 368, the standard speed, at factors 0.1, 0.2, 0.4
# (and none at 0.8 with a 2 ms cap, seeds 1-3)
for s in $(seq 1 8); do for x in 1 2 4; do
  RAYON_NUM_THREADS=1 run std-N368-nonef$x-s$s.json --particles 368 --seed $s --friction none \
    --time-step-factor 0.$x --max-time-step 1ms
  RAYON_NUM_THREADS=1 run std-N368-viscf$x-s$s.json --particles 368 --seed $s --friction viscous \
    --time-step-factor 0.$x --max-time-step 1ms
done; done
for s in 1 2 3; do
  RAYON_NUM_THREADS=1 run std-N368-nonef8c2-s$s.json --particles 368 --seed $s --friction none \
    --time-step-factor 0.8 --max-time-step 2ms
done
# the damper (N = 368, 200 g piston, viscous friction) at five time-step factors
for s in $(seq 1 8); do for x in 0.1 0.2 0.3 0.4 0.8; do
  f=json/damper-f$x-s$s.json
  [ -s "$f" ] || RAYON_NUM_THREADS=1 $B damper --particles 368 --piston-mass 200g --seed $s \
    --time-step-factor $x --max-time-step 1ms --json --out /tmp/magopt-damper-f$x-s$s > "$f"
done; done
python3 summarize.py json > runs.csv
