#!/usr/bin/env bash
# The blast model's exact near field (C8: F = α1/r² − α2/r³ along n_ij, all pairs) in LAMMPS
# and in magopt, on one core each, at the source's case (N = 2000 spheres in R_0 = 1 m,
# mass-based α1 = ᾱ1 m², α2 = ᾱ2 m², m = 3.665 kg). Prints unordered pairs per second and
# their ratio.
#
# LAMMPS (Debian's `lammps`, `lmp`): `pair_style table linear` (tabulated in r², no square
# root: its fastest form of an arbitrary pair law) with a cut-off beyond the cloud's
# diameter, so every pair is summed; Newton's third law on (each unordered pair once); the
# neighbour list built once (`neigh_modify once yes`, the particles barely move in the 20
# steps). Its pair time is read from the "Pair" line of its timing breakdown.
# magopt: `magopt bench blast --threads 1` (the whole interacting run, not only the sum:
# contacts, the integrator and observables are in its wall time, a few per cent); it too
# evaluates each unordered pair once (tiles of 64 particles, src/models/blast/all_pairs.rs).
# Usage: bash bench/lammps/blast-near-field.sh [magopt binary]
set -euo pipefail
bin=${1:-target/release/magopt}
command -v lmp > /dev/null || { echo "lmp not installed (Debian: apt install lammps)"; exit 0; }
work=${KEEP:-$(mktemp -d)}; [ -n "${KEEP:-}" ] || trap 'rm -rf "$work"' EXIT; mkdir -p "$work"
n=2000; steps=20
python3 - "$work/near.table" <<'PY'
import sys, math
m = 7000 * 4 / 3 * math.pi * 0.05**3
a1, a2 = 0.5 * m * m, 0.01 * m * m
lo, hi, k = 0.001, 4.0, 20000
with open(sys.argv[1], "w") as f:
    f.write(f"NEAR\nN {k} RSQ {lo} {hi}\n\n")
    for i in range(k):
        r = math.sqrt(lo * lo + (hi * hi - lo * lo) * i / (k - 1))
        e = -a1 / r + a2 / (2 * r * r)        # potential of F = α1/r² − α2/r³ (attractive +)
        f.write(f"{i + 1} {r:.10g} {e:.10g} {-a1 / r**2 + a2 / r**3:.10g}\n")
PY
cat > "$work/in.near" <<IN
units si
atom_style atomic
boundary f f f
region box block -2 2 -2 2 -2 2
create_box 1 box
region cloud sphere 0 0 0 0.95
create_atoms 1 random $n 4242 cloud
mass 1 3.665
pair_style table linear 20000
pair_coeff 1 1 $work/near.table NEAR 3.9
neighbor 0.0 bin
neigh_modify once yes
timestep 1e-9
fix 1 all nve
thermo 0
run $steps
IN
lmp -in "$work/in.near" -log "$work/log.lammps" -screen none > /dev/null
pair_s=$(awk '/^Pair /{print $5; exit}' "$work/log.lammps")
lammps_rate=$(awk -v n=$n -v s=$steps -v t="$pair_s" 'BEGIN { printf "%.3e", n * (n - 1) / 2 * s / t }')
"$bin" bench blast --threads 1 --interacting-duration 0.02s --out "$work" > /dev/null
magopt_rate=$(jq -r '[.rows[] | select(.model == "interacting")][0].near_field_pairs_per_s' \
  "$work/bench-blast.json" | xargs printf %.3e)
echo "blast near field, N = $n, all pairs, 1 core ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs))"
echo "LAMMPS pair_style table (Newton on): $lammps_rate unordered pairs/s ($pair_s s for $steps steps)"
echo "magopt all-pairs kernel (whole run): $magopt_rate unordered pairs/s"
awk -v a="$magopt_rate" -v b="$lammps_rate" 'BEGIN { printf "ratio magopt / LAMMPS: %.2f\n", a / b }'
