#!/usr/bin/env bash
# The bed's pair kernel (B1: F = 3μ0 μ_i μ_j / (4π r⁴), r < r_c, Verlet list of radius r_v)
# in LAMMPS and in magopt, on one core each, at N = 368 (the source's bed) and N = 3680.
# Prints particle-steps and pair evaluations (unordered pairs inside r_c, each once) per CPU
# second and per wall second, and the ratios magopt / LAMMPS.
#
# magopt: `magopt bench bed --threads 1 --neighbors verlet --tail-correction none
# --time-step-factor 0.2` (the cut-off sums alone, as LAMMPS's table, at the step of the shipped
# ratios; the default with dry friction is 0.4 since 2026-12-05), one full cycle (relaxation,
# compression, expansion; at N = 3680 the piston moves 10× faster to keep the run a few
# minutes long). Its wall time holds everything a step does: pairs, walls,
# gravity, the dry-friction solve, the run checks and observables. Its full lists evaluate
# each unordered pair twice (once from each side); its "pair evaluations" count each once.
# LAMMPS (Debian's `lammps`, `lmp`): the same N, r_c and skin r_v − r_c (from magopt's JSON),
# `pair_style table linear` of F = 1/r⁴ in reduced units (LAMMPS's fastest form of an
# arbitrary pair law), Newton's third law on (a half list: each unordered pair once), rebuilt
# on half-skin displacements like magopt's (`neigh_modify every 1 delay 0 check yes`); in a
# cell of the same width W (in D) with WCA walls at its four sides, at magopt's step-mean
# packing fraction: the piston height varies over the cycle and the pairs per particle with
# it, and the step mean is what the cycle's mean cost per step sees. LAMMPS keeps that height
# fixed (no piston, no gravity: its discs fill the cell evenly, while magopt's crowd towards
# the floor and have more partners at the same mean packing fraction) and its discs damped
# (`fix viscous`) from a jittered grid; both codes' pairs per particle are printed, and the
# per-pair ratio does not depend on them. Each measurement runs twice; the better run (per
# CPU second) is kept.
# AT_ONCE=1 then also runs both codes at the same time, each pinned to one of the first two
# cores (`taskset`), twice with the cores swapped, and prints those repeats' ratios
# ("at once" lines): on a machine whose speed drifts over minutes, runs one after the other
# compare different speeds, while runs at the same time see the same drift (both share the
# caches and the memory, so both run slower than alone).
# Usage: [AT_ONCE=1] [BED_CASES="368:5.63mm/s 3680:56.3mm/s"] bash bench/lammps/bed-pairs.sh
# [magopt binary] (N:piston speed pairs)
set -euo pipefail
here=$(dirname "$0")
source "$here/lib.sh"
prepare "$@"
echo "bed pair kernel vs LAMMPS, 1 core each ($(machine))"
printf '%6s %-7s %10s %9s %9s %7s %14s %14s %14s %14s\n' N code steps pairs/p list/p builds \
  p-steps/cpu-s pairs/cpu-s p-steps/wall-s pairs/wall-s
bed_case() {
  local n=$1 speed=$2 m=$work/magopt-$1
  magopt_best_of_two "$m" ".rows[0].particle_steps_per_cpu_s" \
    "$bin" bench bed --threads 1 --neighbors verlet --tail-correction none --time-step-factor 0.2 --particles "$n" \
      --velocity "$speed"
  local row=".rows[0]"
  read -r steps phi rc rv width pp lp builds mps mpe mpsw mpew < <(jq -r "$row | [.steps,
    .mean_packing_fraction, .cutoff_D, .list_radius_D, .cell_width_D, .pairs_per_particle,
    .list_entries_per_particle, .list_builds, .particle_steps_per_cpu_s,
    .pair_evaluations_per_cpu_s, .particle_steps_per_s, .pair_evaluations_per_s] | @tsv" "$m.json")
  python3 - "$work" "$n" "$phi" "$width" "$rc" <<'PY'
import math, random, sys
work, n, phi, width, rc = sys.argv[1], int(sys.argv[2]), *map(float, sys.argv[3:])
height = n * math.pi / 4 / (width * phi)       # discs of diameter 1 at packing fraction phi
nx = max(1, round(math.sqrt(n * width / height)))
ny = math.ceil(n / nx)
sx, sy = width / nx, height / ny
rng = random.Random(1)
with open(f"{work}/bed-{n}.data", "w") as f:
    f.write(f"bed\n\n{n} atoms\n1 atom types\n\n0 {width} xlo xhi\n0 {height} ylo yhi\n-0.5 0.5 zlo zhi\n\nAtoms\n\n")
    for k in range(n):
        i, j = k % nx, k // nx
        jx, jy = (rng.uniform(-0.1, 0.1) * min(sx, sy) for _ in range(2))
        f.write(f"{k + 1} 1 {(i + 0.5) * sx + jx:.9g} {(j + 0.5) * sy + jy:.9g} 0\n")
lo, k = 0.3, 20000                             # F = 1/r^4, E = 1/(3 r^3), tabulated in r^2
with open(f"{work}/r4.table", "w") as f:
    f.write(f"R4\nN {k} RSQ {lo} {rc}\n\n")
    for m in range(k):
        r = math.sqrt(lo * lo + (rc * rc - lo * lo) * m / (k - 1))
        f.write(f"{m + 1} {r:.10g} {1 / (3 * r**3):.10g} {1 / r**4:.10g}\n")
PY
  cat > "$work/in.bed-$n" <<IN
units lj
dimension 2
boundary f f p
atom_style atomic
read_data $work/bed-$n.data
mass 1 1.0
pair_style table linear 20000
pair_coeff 1 1 $work/r4.table R4 $rc
neighbor $(awk -v a="$rv" -v b="$rc" 'BEGIN {print a - b}') bin
neigh_modify every 1 delay 0 check yes
fix walls all wall/lj126 xlo EDGE 1.0 0.5 0.5612 xhi EDGE 1.0 0.5 0.5612 ylo EDGE 1.0 0.5 0.5612 yhi EDGE 1.0 0.5 0.5612
fix move all nve
fix damp all viscous 1.0
fix plane all enforce2d
compute coordination all coord/atom cutoff $rc
compute partners all reduce ave c_coordination
thermo_style custom step c_partners
thermo $steps
timestep 0.005
run $steps
thermo_style custom step
uncompute partners
uncompute coordination
run 0
IN
  local log=$work/log.bed-$n
  lmp_best_of_two "$work/in.bed-$n" "$log"
  local cpu wall lpp lnb lbuilds
  cpu=$(lmp_cpu_s "$log"); wall=$(lmp_loop_s "$log")
  lpp=$(lmp_thermo_mean "$log" c_partners)  # at the first and last step
  lnb=$(lmp_half_list "$log")
  lbuilds=$(lmp_builds "$log")
  local lps lpe lpsw lpew
  read -r lps lpe lpsw lpew < <(lammps_rates "$n" "$lpp" "$steps" "$cpu" "$wall")
  printf '%6s %-7s %10s %9.2f %9.2f %7s %14s %14s %14s %14s\n' "$n" magopt "$steps" "$pp" "$lp" \
    "$builds" "$(sci "$mps")" "$(sci "$mpe")" "$(sci "$mpsw")" "$(sci "$mpew")"
  # LAMMPS's list is a half list: its entries per particle, doubled, compare with magopt's
  printf '%6s %-7s %10s %9.2f %9.2f %7s %14s %14s %14s %14s\n' "$n" LAMMPS "$steps" "$lpp" \
    "$(awk -v h="$lnb" 'BEGIN {print 2 * h}')" "$lbuilds" "$(sci "$lps")" "$(sci "$lpe")" \
    "$(sci "$lpsw")" "$(sci "$lpew")"
  awk -v n="$n" -v w="$width" -v p="$phi" -v c="$rc" -v v="$rv" -v ps="$(lmp_pair_s "$log")" \
    -v t="$wall" -v u="$(lmp_cpu_use "$log")" 'BEGIN {printf "       (step-mean packing \
fraction %.4f, cell %.2f × %.2f D, r_c = %s D, r_v = %s D; LAMMPS pair time %.3g of %.3g s, \
CPU use %.2f)\n", p, w, n * 3.14159265 / 4 / (w * p), c, v, ps, t, u}'
  summary+=("summary|bed r⁻⁴ N=$n|$(ratio "$mps" "$lps")|$(ratio "$mpe" "$lpe")")
  if [ -n "${AT_ONCE:-}" ]; then at_once "$n" "$speed" "$steps" "$lpp"; fi
}
# Both codes at the same time, one per core, twice with the cores swapped; the ratios per CPU
# second of particle-steps and of pair evaluations (each code's own pairs per particle).
at_once() {
  local n=$1 speed=$2 steps=$3 lpp=$4 k log out lps mps mpp
  command -v taskset > /dev/null || { echo "taskset not installed: AT_ONCE skipped"; return; }
  for k in 0 1; do
    log=$work/log.once-$n.$k out=$work/once-$n.$k
    taskset -c "$k" lmp -in "$work/in.bed-$n" -log "$log" -screen none > /dev/null &
    RAYON_NUM_THREADS=1 taskset -c "$((1 - k))" "$bin" bench bed --threads 1 --neighbors verlet \
      --tail-correction none --time-step-factor 0.2 --particles "$n" --velocity "$speed" --out "$out" > /dev/null
    wait
    lps=$(awk -v n="$n" -v s="$steps" -v t="$(lmp_cpu_s "$log")" 'BEGIN {print n * s / t}')
    read -r mps mpp < <(jq -r '.rows[0] | [.particle_steps_per_cpu_s, .pairs_per_particle] |
      @tsv' "$out/"*.json)
    summary+=("at once (LAMMPS on core $k)|bed r⁻⁴ N=$n|$(ratio "$mps" "$lps")|$(ratio \
      "$(awk -v a="$mps" -v p="$mpp" 'BEGIN {print a * p}')" \
      "$(awk -v a="$lps" -v p="$lpp" 'BEGIN {print a * p}')")")
  done
}
summary=()
for case in ${BED_CASES:-368:5.63mm/s 3680:56.3mm/s}; do bed_case "${case%%:*}" "${case#*:}"; done
echo "ratios magopt / LAMMPS per CPU second (particle-steps, pair evaluations):"
printf '%s\n' "${summary[@]}"
