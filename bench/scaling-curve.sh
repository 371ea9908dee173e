#!/usr/bin/env bash
# The thread-scaling curve of every model (issue 18, item 5): each model's N = 1e4 workload
# run once per thread count, with its wall time, the speed-up over one thread and whether its
# result is the one-thread result (the JSON with its wall-time fields left out).
#
#   bash bench/scaling-curve.sh [magopt binary] [thread counts] > curve.md
#
# Thread counts default to "1 2 4 8 16"; counts above the machine's logical cores are
# skipped. Sized for a lent 16-core machine, where all of it should take under two minutes
# (70 s on 2 cores with "1 2"): the bed's first 3000 steps, align end to end, and blast's
# cloud scaled to N = 1e4 for its first 0.01 s (its expansion; the collapse that follows
# takes minutes). Give it a quiet machine. Exit codes: 0; 1 on a failed run or a missing
# binary.
set -euo pipefail
shopt -s inherit_errexit

# shellcheck source=bench/runs.sh
source "$(dirname "$0")/runs.sh"
magopt_bin "${1:-}"
threads=${2:-1 2 4 8 16}

workloads=(
    "${n1e4_workloads[@]}"
    # the source's cloud (1 m, 10 kJ, about 2000 particles) scaled to 1e4 at its packing
    # fraction and energy per particle, as `magopt bench blast --scale-cloud` does
    "blast N=1e4 scaled cloud, 0.01 s|blast --json --interacting --particles 10000 --cloud-radius 1.70998m --energy 50kJ --duration 0.01s"
)

# The run's JSON without its wall-time fields, as one line (what must not depend on threads).
result_of() {
    python3 -c '
import json, sys
d = json.load(sys.stdin)
print(json.dumps({k: v for k, v in d.items() if "wall" not in k}, sort_keys=True))'
}

out=$(mktemp)
trap 'rm -f "$out"' EXIT
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) logical cores; load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
printf '| workload | threads | wall (s) | speed-up | per thread | same result as 1 thread |\n'
printf '|---|---|---|---|---|---|\n'
for workload in "${workloads[@]}"; do
    name=${workload%%|*}
    read -ra args <<< "${workload#*|}"
    t1="" reference=""
    for t in $threads; do
        [ "$t" -le "$(nproc)" ] || continue
        start=$(date +%s.%N)
        # exit code 3 (run ended before its target) is a finished run here
        RAYON_NUM_THREADS=$t "$bin" "${args[@]}" > "$out" || [ $? -eq 3 ] ||
            { echo "failed: RAYON_NUM_THREADS=$t $bin ${args[*]}" >&2; exit 1; }
        wall=$(echo "$(date +%s.%N) - $start" | bc -l)
        result=$(result_of < "$out")
        if [ -z "$t1" ]; then
            t1=$wall reference=$result
        fi
        same=$([ "$result" = "$reference" ] && echo yes || echo NO)
        printf '| %s | %s | %.2f | %.2f | %.2f | %s |\n' "$name" "$t" "$wall" \
            "$(echo "$t1 / $wall" | bc -l)" "$(echo "$t1 / $wall / $t" | bc -l)" "$same"
    done
done
