#!/usr/bin/env bash
# The bed's far-field modes against exact sums: one standard cycle per (N, seed, mode), the
# relative error of F_max and of the cycle work against the exact run of the same N and seed,
# and the CPU seconds of each run (per-core cost, meaningful on a shared machine).
#
#   bash bench/bed-far-field.sh [magopt binary] [output directory]
#
# SIZES (368), SEEDS (1), SPEED (piston speed; 5.63mm/s) and MODES (the runs beside exact,
# one "label|flags" per line, labels tree-θ[-K<interval>]) choose the cases; runs whose JSON exists are reused (resume). The table
# goes to stdout and is appended to OUT/table.md.
set -euo pipefail
bin=${1:-target/release/magopt}
out=${2:-results/bench/bed-far-field}
sizes=${SIZES:-368}
seeds=${SEEDS:-1}
speed=${SPEED:-5.63mm/s}
modes=${MODES:-"verlet|--neighbors verlet --tail-correction none
tree-0.3|--neighbors tree --opening-angle 0.3
tree-0.3-K4|--neighbors tree --opening-angle 0.3 --far-field-interval 4
tree-0.1|--neighbors tree --opening-angle 0.1"}
mkdir -p "$out"

# run LABEL N SEED FLAGS...: one cycle into $out/LABEL-N-sSEED.json (+ .cpu, user+sys s)
run() {
  local label=$1 n=$2 s=$3
  shift 3
  local base="$out/$label-N$n-s$s-${speed//\//_}"
  [ -s "$base.json" ] && { echo "$base"; return; }
  # exit 3 is a failed run whose JSON says why; anything else leaves no record
  local code=0
  # at the time-step factor of the shipped tables (the default since 2026-12-05 is 0.4 with dry friction)
  /usr/bin/time -f "%U %S" -o "$base.cpu" "$bin" bed --particles "$n" --seed "$s" \
    --piston-speed "$speed" --time-step-factor 0.2 "$@" --json > "$base.json.tmp" || code=$?
  if [ "$code" -ne 0 ] && [ "$code" -ne 3 ]; then
    rm -f "$base.json.tmp" "$base.cpu"
    echo "run $label N=$n seed $s: magopt exited $code" >&2
    return 1
  fi
  mv "$base.json.tmp" "$base.json"
  echo "$base"
}

field() { jq -r ".$2" "$1.json"; }
# CPU seconds of a run (– for a run copied from elsewhere without them)
cpu() { [ -s "$1.cpu" ] && tail -1 "$1.cpu" | awk '{printf "%.0f", $1 + $2}' || echo –; }

{
  echo
  echo "Piston speed $speed:"
  echo
  echo "| N | seed | mode | F_max (N) | error | cycle work (J) | error | CPU s |"
  echo "|---|---|---|---|---|---|---|---|"
  for n in $sizes; do
    for s in $seeds; do
      exact=$(run exact "$n" "$s" --neighbors exact) || continue
      f0=$(field "$exact" max_piston_force_N)
      w0=$(field "$exact" cycle_work_J)
      printf "| %s | %s | exact | %.3f | | %.4f | | %s |\n" "$n" "$s" "$f0" "$w0" "$(cpu "$exact")"
      while IFS='|' read -r label flags; do
        # shellcheck disable=SC2086
        r=$(run "$label" "$n" "$s" $flags) || {
          echo "| $n | $s | $label | no record | | | | |"
          continue
        }
        f=$(field "$r" max_piston_force_N)
        w=$(field "$r" cycle_work_J)
        awk -v n="$n" -v s="$s" -v l="$label" -v f="$f" -v w="$w" -v f0="$f0" -v w0="$w0" \
          -v c="$(cpu "$r")" 'BEGIN { printf "| %s | %s | %s | %.3f | %+.2f %% | %.4f | %+.2f %% | %s |\n",
            n, s, l, f, 100 * (f / f0 - 1), w, 100 * (w / w0 - 1), c }'
      done <<< "$modes"
    done
  done
} | tee -a "$out/table.md"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) logical cores, load average $(cut -d' ' -f1 /proc/loadavg)" | tee -a "$out/table.md"
