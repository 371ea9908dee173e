# Shell helpers shared by the LAMMPS side-by-side scripts (sourced, not run).
# Conventions: one core each (LAMMPS: 1 MPI rank, no OpenMP; magopt: --threads 1); rates per
# CPU second (the loop's wall time times LAMMPS's "% CPU use"; magopt's process CPU time),
# which are per-core rates even when other jobs share the machine, and per wall second.

# Exits 0 with a note where LAMMPS is absent (the comparison is optional).
require_lmp() {
  command -v lmp > /dev/null || { echo "lmp not installed (Debian: apt install lammps): LAMMPS comparison skipped"; exit 0; }
  command -v jq > /dev/null || { echo "jq not installed: LAMMPS comparison skipped"; exit 0; }
}

# The common start of every script: $bin from its first argument (default
# target/release/magopt), LAMMPS and jq present, a scratch directory in $work.
prepare() {
  bin=${1:-target/release/magopt}
  require_lmp
  scratch
}

# A scratch directory ($KEEP keeps it) in $work.
scratch() {
  work=${KEEP:-$(mktemp -d)}
  [ -n "${KEEP:-}" ] || trap 'rm -rf "$work"' EXIT
  mkdir -p "$work"
}

# The machine, for the record: CPU model, logical cores, 1-minute load average.
machine() {
  echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) logical cores, load average $(cut -d' ' -f1 /proc/loadavg)"
}

# LAMMPS log figures: loop wall time (s), CPU use (fraction), steps, atoms, neighbour-list
# builds, "Pair" time (s).
lmp_loop_s() { awk '/^Loop time of/ {print $4; exit}' "$1"; }
lmp_cpu_use() { awk '/CPU use with/ {for (i = 1; i <= NF; i++) if ($i ~ /%$/) {sub("%", "", $i); print $i / 100; exit}}' "$1"; }
lmp_steps() { awk '/^Loop time of/ {print $9; exit}' "$1"; }
lmp_builds() { awk '/^Neighbor list builds/ {print $NF; exit}' "$1"; }
lmp_pair_s() { awk '/^Pair / {print $5; exit}' "$1"; }
# The first run's thermo values of column $2 (thermo_style custom ... $2 ...): the last one,
# and the mean of all.
lmp_thermo_last() { lmp_thermo "$1" "$2" | tail -1; }
lmp_thermo_mean() { lmp_thermo "$1" "$2" | awk '{s += $1; k++} END {print s / k}'; }
lmp_thermo() {
  awk -v col="$2" '$1 == "Step" {for (i = 1; i <= NF; i++) if ($i == col) c = i; next}
    /^Loop time/ {exit} c && $1 ~ /^[0-9]+$/ {print $c}' "$1"
}
# Half-list entries per atom of the pair style's list: the decks end with a `run 0` after
# their computes are removed, so the last count is that list's alone (a compute's occasional
# full list would otherwise be the one counted).
lmp_half_list() { awk '/^Ave neighs\/atom/ {v = $NF} END {print v}' "$1"; }

# Runs a LAMMPS deck twice; keeps the log of the faster loop (per CPU second) as $2.
lmp_best_of_two() {
  local deck=$1 log=$2 k best=""
  for k in 1 2; do
    lmp -in "$deck" -log "$log.$k" -screen none > /dev/null
    if [ -z "$best" ] || awk -v a="$(lmp_cpu_s "$log.$k")" -v b="$(lmp_cpu_s "$best")" 'BEGIN {exit !(a < b)}'; then
      best=$log.$k
    fi
  done
  cp "$best" "$log"
}
# A LAMMPS run of $1 particles with $2 pairs (contacts) per particle over $3 steps in $4 CPU
# seconds and $5 wall seconds: particle-steps and pair evaluations (each pair once) per CPU
# second, then the same per wall second.
lammps_rates() {
  awk -v n="$1" -v p="$2" -v s="$3" -v c="$4" -v w="$5" \
    'BEGIN {print n * s / c, n * p / 2 * s / c, n * s / w, n * p / 2 * s / w}'
}
# The loop's CPU seconds: wall time times CPU use.
lmp_cpu_s() { awk -v t="$(lmp_loop_s "$1")" -v u="$(lmp_cpu_use "$1")" 'BEGIN {print t * u}'; }

# Runs a magopt bench twice (the same arguments, --out added); keeps as $1.json the JSON
# with the larger value of the jq expression $2 (a rate).
magopt_best_of_two() {
  local out=$1 key=$2 k; shift 2
  for k in 1 2; do
    "$@" --out "$out.$k" > /dev/null
  done
  if awk -v a="$(jq -r "$key" "$out.1/"*.json)" -v b="$(jq -r "$key" "$out.2/"*.json)" 'BEGIN {exit !(a >= b)}'; then
    cp "$out.1/"*.json "$out.json"
  else
    cp "$out.2/"*.json "$out.json"
  fi
}

# a / b to 2 decimals.
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
# x in %.3e.
sci() { awk -v x="$1" 'BEGIN { printf "%.3e", x }'; }
