#!/usr/bin/env bash
# The align model's settling (packing stages 1 and 2: spheres from a loose random start settle
# in an open-topped die under a downward force, Hertz contacts, FIRE) in magopt and a granular
# pour in LAMMPS (`pair_style gran/hertz/history`: Hertz normal force with tangential history
# friction), on one core each, at N = 1000 and 10000. Prints particle-steps and contact
# evaluations (touching pairs, each once) per CPU second and per wall second, and the ratios
# magopt / LAMMPS.
#
# magopt: `magopt bench align --threads 1`, its packing stages 1 and 2 (`fire_stages`:
# overlap removal and settling, FIRE steps of one force evaluation each, frictionless contacts;
# the FIRE update, rest checks and reductions are in their time). The release that follows is
# left out: since 2026-12-03 it takes backward-Euler steps solved by Newton's method, several
# contact sums each, which no pour does (with it the whole packing ran as many LAMMPS steps as
# its FIRE steps and evaluations together, and LAMMPS's pour, far from settled after them,
# averaged half magopt's contacts at N = 10⁴). The stages' wall time over the packing's CPU use
# gives their CPU seconds. Its full lists evaluate each pair from both sides; its "contact
# evaluations" count each once.
# LAMMPS (Debian's `lammps`, `lmp`): the same N and size distribution (log-normal diameters,
# σ = 0.10, mean radius 1: AlignParams::paper_defaults), unit masses, the same list skin
# as magopt's FIRE stages (0.45 mean radii since 2026-12-07, 0.3 before; LAMMPS ran as fast
# with either, within 2 %), Hertz stiffness 4E*/3 with E* = 1/(2(1 − ν²)), ν = 0.3, the same
# downward force per particle (1e-3), a die of the same side (solid volume / 0.6 to the 1/3)
# with granular walls, poured from a loose jittered lattice three sides high; Newton's
# third law on (a half list: each pair once); friction μ = 0.2 with its shear history (the
# align model's particle friction; magopt's settling is frictionless, so LAMMPS does more
# per contact); velocity Verlet with contact damping instead of FIRE. LAMMPS pours for as many
# steps as magopt's stages 1 and 2 took, untimed, then is timed over as many more: FIRE settles
# in fewer steps than a damped pour, and timed from the loose start LAMMPS averaged half
# magopt's contacts per particle at N = 10⁴ (2.72 against 5.47; 3.92 against 4.83 at 10³).
# Both codes' step-mean contacts per particle are printed (the per-contact ratio does not
# depend on a residual difference). Each measurement runs twice; the better is kept.
# Usage: [ALIGN_SIZES="1000 10000"] bash bench/lammps/align-hertz.sh [magopt binary]
set -euo pipefail
here=$(dirname "$0")
source "$here/lib.sh"
prepare "$@"
echo "align settling contacts vs LAMMPS gran/hertz/history, 1 core each ($(machine))"
printf '%6s %-7s %8s %10s %9s %14s %14s %14s %14s\n' N code steps contacts/p list/p \
  p-steps/cpu-s contacts/cpu-s p-steps/wall-s contacts/wall-s
align_case() {
  local n=$1 m=$work/magopt-$1
  magopt_best_of_two "$m" ".rows[0].fire_stages.particle_steps_per_s" \
    "$bin" bench align --threads 1 --max-steps 1 --particles "$n"
  # per CPU second: the stages' wall rates over the packing's CPU use (CPU s / wall s)
  read -r steps cp lp mps mpe mpsw mpew < <(jq -r '.rows[0] | (.settle_cpu_s / .settle_s) as $use
    | .fire_stages | [.steps, .contacts_per_particle, .list_entries_per_particle,
    .particle_steps_per_s / $use, .contact_evaluations_per_s / $use,
    .particle_steps_per_s, .contact_evaluations_per_s] | @tsv' "$m.json")
  local side
  side=$(python3 - "$work/pour-$n.data" "$n" 0.10 <<'PY'
import math, random, sys
path, n, sigma = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rng = random.Random(1)
radius = [math.exp(sigma * rng.gauss(0, 1) - sigma * sigma / 2) for _ in range(n)]
side = max((sum(4 / 3 * math.pi * r**3 for r in radius) / 0.6) ** (1 / 3), 2 * max(radius))
a = 2 * max(radius) * 1.05                      # lattice spacing: no overlaps at the start
m = int(side // a)
layers = -(-n // (m * m))                       # as high as needed (at least 3 sides, as magopt)
top = max(3 * side, layers * a)
sites = [(i, j, k) for k in range(layers) for j in range(m) for i in range(m)]
with open(path, "w") as f:
    f.write(f"pour\n\n{n} atoms\n1 atom types\n\n0 {side} xlo xhi\n0 {side} ylo yhi\n0 {top} zlo zhi\n\nAtoms\n\n")
    for q, (r, (i, j, k)) in enumerate(zip(radius, sites)):
        x, y, z = ((c + 0.5) * a + rng.uniform(-0.02, 0.02) * a for c in (i, j, k))
        f.write(f"{q + 1} 1 {2 * r:.9g} {3 / (4 * math.pi * r**3):.9g} {x:.9g} {y:.9g} {z:.9g}\n")
print(side)
PY
)
  # the pour: the first $steps steps untimed (written out), the next $steps timed, so that
  # LAMMPS's contacts per particle over its timed steps come near magopt's step mean
  pour_deck "$work/pour-$n.data" "$side" "$steps" "write_data $work/poured-$n.data" \
    > "$work/in.pour-$n-first"
  lmp -in "$work/in.pour-$n-first" -log "$work/log.pour-$n-first" -screen none > /dev/null
  pour_deck "$work/poured-$n.data" "$side" "$steps" "" > "$work/in.pour-$n"
  local log=$work/log.pour-$n
  lmp_best_of_two "$work/in.pour-$n" "$log"
  local cpu wall lcp lnb
  cpu=$(lmp_cpu_s "$log"); wall=$(lmp_loop_s "$log")
  # step-mean contacts per particle: the mean of the thermo samples
  lcp=$(lmp_thermo_mean "$log" c_mean_contacts)
  lnb=$(lmp_half_list "$log")
  local lps lpe lpsw lpew
  read -r lps lpe lpsw lpew < <(lammps_rates "$n" "$lcp" "$steps" "$cpu" "$wall")
  printf '%6s %-7s %8s %10.2f %9.2f %14s %14s %14s %14s\n' "$n" magopt "$steps" "$cp" "$lp" \
    "$(sci "$mps")" "$(sci "$mpe")" "$(sci "$mpsw")" "$(sci "$mpew")"
  # LAMMPS's list is a half list (at the run's end): its entries per particle, doubled
  printf '%6s %-7s %8s %10.2f %9.2f %14s %14s %14s %14s\n' "$n" LAMMPS "$steps" "$lcp" \
    "$(awk -v h="$lnb" 'BEGIN {print 2 * h}')" "$(sci "$lps")" "$(sci "$lpe")" \
    "$(sci "$lpsw")" "$(sci "$lpew")"
  echo "       (LAMMPS pair time $(lmp_pair_s "$log") of $wall s, $(lmp_cpu_use "$log") CPU use, $(lmp_builds "$log") list builds; contacts at its end $(lmp_thermo_last "$log" c_mean_contacts))"
  summary+=("summary|align settling Hertz N=$n|$(ratio "$mps" "$lps")|$(ratio "$mpe" "$lpe")")
}
# A LAMMPS pour deck: the spheres of data file $1 in a die of side $2, $3 steps, then command
# $4; its thermo output the step-mean contacts per particle.
pour_deck() {
  local hertz="hertz/history 0.7326 NULL 0.5 NULL 0.2 1"
  cat <<IN
units lj
atom_style sphere
boundary f f f
read_data $1
pair_style gran/$hertz
pair_coeff * *
comm_modify vel yes
neighbor 0.45 bin
neigh_modify every 1 delay 0 check yes
fix wall_x all wall/gran $hertz xplane 0 $2
fix wall_y all wall/gran $hertz yplane 0 $2
fix floor all wall/gran $hertz zplane 0 NULL
fix move all nve/sphere
fix down all gravity 1e-3 vector 0 0 -1
compute contacts all contact/atom
compute mean_contacts all reduce ave c_contacts
thermo_style custom step c_mean_contacts
thermo $(( ($3 + 49) / 50 ))
timestep 0.1
run $3
thermo_style custom step
uncompute mean_contacts
uncompute contacts
run 0
$4
IN
}
summary=()
for n in ${ALIGN_SIZES:-1000 10000}; do align_case "$n"; done
echo "ratios magopt / LAMMPS per CPU second (particle-steps, contact evaluations):"
printf '%s\n' "${summary[@]}"
