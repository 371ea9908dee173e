#!/usr/bin/env bash
# The blast model's exact near field (C8: F = α1/r² − α2/r³ along n_ij, all pairs) in LAMMPS
# and in magopt, on one core each, at the source's case (N = 2000 spheres in R_0 = 1 m,
# mass-based α1 = ᾱ1 m², α2 = ᾱ2 m², m = 3.665 kg). Prints unordered pairs per second and
# their ratio, per CPU second (LAMMPS: its Pair time times its CPU use; magopt: process CPU
# time; per-core rates even on a loaded machine) and per wall second. Each code runs twice;
# the better run is kept.
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
source "$(dirname "$0")/lib.sh"
prepare "$@"
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
lmp_best_of_two "$work/in.near" "$work/log.lammps"
pair_s=$(lmp_pair_s "$work/log.lammps")
pair_cpu_s=$(awk -v t="$pair_s" -v u="$(lmp_cpu_use "$work/log.lammps")" 'BEGIN {print t * u}')
lammps_wall=$(awk -v n=$n -v s=$steps -v t="$pair_s" 'BEGIN {print n * (n - 1) / 2 * s / t}')
lammps_cpu=$(awk -v n=$n -v s=$steps -v t="$pair_cpu_s" 'BEGIN {print n * (n - 1) / 2 * s / t}')
row='[.rows[] | select(.model == "interacting double")][0]'
magopt_best_of_two "$work/magopt" "$row.near_field_pairs_per_cpu_s" \
  "$bin" bench blast --threads 1 --interacting-duration 0.02s --near-field-precision double
magopt_wall=$(jq -r "$row.near_field_pairs_per_s" "$work/magopt.json")
magopt_cpu=$(jq -r "$row.near_field_pairs_per_cpu_s" "$work/magopt.json")
echo "blast near field, N = $n, all pairs, 1 core ($(machine))"
echo "LAMMPS pair_style table (Newton on): $(sci "$lammps_cpu") unordered pairs per CPU s, $(sci "$lammps_wall") per wall s ($pair_s s for $steps steps)"
echo "magopt all-pairs kernel (whole run): $(sci "$magopt_cpu") unordered pairs per CPU s, $(sci "$magopt_wall") per wall s"
echo "ratio magopt / LAMMPS: $(ratio "$magopt_cpu" "$lammps_cpu") per CPU s, $(ratio "$magopt_wall" "$lammps_wall") per wall s"
echo "summary|blast near field N=$n|–|$(ratio "$magopt_cpu" "$lammps_cpu")"
