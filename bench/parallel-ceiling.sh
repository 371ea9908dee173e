#!/usr/bin/env bash
# What two threads can gain on this machine, beside what magopt's two threads gain.
#
#   bash bench/parallel-ceiling.sh [magopt binary] [repeats]
#
# For each workload (one run of each model at N ≈ 1e4 or the largest its model holds), three
# measurements of wall time: the run alone on one thread (t1); two copies of it at once, one
# thread each (t_pair: the mean of the two); the run on two threads (t2). Then
#   ceiling  = 2 t1 / t_pair   the throughput two independent single-threaded jobs get from the
#                              two cores (2 on two full cores; less where the cores share caches,
#                              memory bandwidth or, on a VM, a physical core),
#   speed-up = t1 / t2         what magopt's parallel loops get,
#   share    = speed-up / ceiling = t_pair / (2 t2).
# A speed-up below 1.8 with a ceiling near it is the machine's limit, not the code's. Give it a
# quiet machine: anything else running lowers both figures. Exit codes: 0, or 1 on a failed run.
set -euo pipefail
shopt -s inherit_errexit   # a failed run inside $(…) stops the script too

# shellcheck source=bench/runs.sh
source "$(dirname "$0")/runs.sh"
magopt_bin "${1:-}"
repeats=${2:-2}

workloads=(
    "${n1e4_workloads[@]}"
    "blast N=2000 interacting, 0.1 s|blast --json --interacting --duration 0.1s"
)

# Wall seconds of one run of magopt with these arguments on `threads` threads.
timed() {
    local threads=$1
    shift
    local start end
    start=$(date +%s.%N)
    # exit code 3 (run ended before its target) is a finished run here
    RAYON_NUM_THREADS=$threads "$bin" "$@" > /dev/null || [ $? -eq 3 ] ||
        { echo "failed: $bin $*" >&2; return 1; }
    end=$(date +%s.%N)
    echo "$end - $start" | bc -l
}

# Wall seconds of two copies at once, one thread each: the mean of the two.
timed_pair() {
    local a b
    a=$(mktemp)
    b=$(mktemp)
    timed 1 "$@" > "$a" &
    local pa=$!
    timed 1 "$@" > "$b" &
    local pb=$!
    wait $pa
    wait $pb
    echo "($(cat "$a") + $(cat "$b")) / 2" | bc -l
    rm -f "$a" "$b"
}

echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) logical cores; load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
printf '| workload | repeat | t1 (s) | two copies (s) | t2 (s) | ceiling | speed-up | share |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for w in "${workloads[@]}"; do
    name=${w%%|*}
    read -r -a args <<< "${w#*|}"
    for r in $(seq 1 "$repeats"); do
        t1=$(timed 1 "${args[@]}")
        tp=$(timed_pair "${args[@]}")
        t2=$(timed 2 "${args[@]}")
        printf '| %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n' "$name" "$r" "$t1" "$tp" "$t2" \
            "$(echo "2 * $t1 / $tp" | bc -l)" "$(echo "$t1 / $t2" | bc -l)" \
            "$(echo "$tp / (2 * $t2)" | bc -l)"
    done
done
