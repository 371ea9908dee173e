#!/usr/bin/env bash
# Run one study as a Slurm job array: each array task runs one deterministic slice (shard) of the
# run list into its own directory, and `magopt collect` merges the shards into one result that
# is identical to an unsharded sweep (runs are identified by their parameters and seed).
# Tested recipe and details: studies/SLURM.md.
#
# Submit the array and a dependent collect job in one go (prints both job ids):
#   studies/slurm-array.sh submit STUDY.toml 0-15 [SBATCH_OPTION...]
#     e.g. studies/slurm-array.sh submit studies/align-tau-vs-field-friction.toml 0-15 \
#            --cpus-per-task=8 --time=02:00:00 --partition=compute
#   (the SBATCH_OPTIONs go to both jobs; the collect job always asks for 1 CPU)
#
# Or by hand, in two steps:
#   sbatch --array=0-15 --cpus-per-task=8 studies/slurm-array.sh STUDY.toml     # the shards
#   studies/slurm-array.sh collect STUDY.toml        # when all tasks are done (or via sbatch
#                                                     # --dependency=afterok:JOBID)
#
# Modes and options (options go before STUDY.toml):
#   [task] STUDY.toml       one array task: shard I of N, from the Slurm array variables
#   collect STUDY.toml [N]  merge shards 0..N-1 (N: inferred when only one shard count exists)
#   submit STUDY.toml ARRAY [SBATCH_OPTION...]
#   --threads N    worker threads (default: SLURM_CPUS_PER_TASK, else `nproc`)
#   --results DIR  results root (default: $MAGOPT_RESULTS, else ./results)
#   --out DIR      where collect writes the merged result (default: RESULTS/<name>-<hash>)
#   --range A-B    the full array range, for rerunning some tasks of it: shard = ID - A of B-A+1
#                  (sbatch --array=2,5 studies/slurm-array.sh --range 0-15 STUDY.toml)
#   --materials F  passed to `magopt sweep` and `magopt collect`
# Environment: MAGOPT (the binary, default `magopt` on PATH), MAGOPT_RESULTS.
#
# Shard index = SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN and shard count =
# SLURM_ARRAY_TASK_COUNT, so --array=0-3 and --array=1-4 both give shards 0..3 of 4; a stepped or
# sparse array (0-6:2, 1,3,5) is refused unless --range gives the full range. A `%` throttle
# (0-15%4) is fine.
# Shard directories are RESULTS/shards/<name>-<hash>/shard-I-of-N, where <hash> is the first
# 10 hex digits of the SHA-256 of the study file's absolute path: studies/a/x.toml and
# studies/b/x.toml never share a directory. Tasks use --resume, so resubmitting the array (or
# only the failed tasks, with --range) continues where it stopped.
# To test a task locally, set the variables by hand:
#   SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MIN=0 SLURM_ARRAY_TASK_MAX=3 SLURM_ARRAY_TASK_COUNT=4 \
#     studies/slurm-array.sh STUDY.toml
#
# `magopt collect` exits non-zero when runs are missing from the shards (exit 4, unless
# --allow-partial); this script treats any non-zero exit as failure and exits with it, and it
# fails before calling collect if a shard directory is missing. Binaries older than that change
# exit 0 on a partial collect: check "collected n of total" in the log.
#
#SBATCH --job-name=magopt
set -euo pipefail

magopt=${MAGOPT:-magopt}
results=${MAGOPT_RESULTS:-results}
threads=""
out=""
range=""
materials=()

# Progress and the commands run go to stderr; stdout is left for `submit`'s job ids.
say() { printf 'slurm-array.sh: %s\n' "$*" >&2; }
die() {
  printf 'slurm-array.sh: error: %s\n' "$*" >&2
  exit 2
}
# Prints a command, then runs it.
run() {
  {
    printf 'slurm-array.sh: +'
    printf ' %q' "$@"
    printf '\n'
  } >&2
  "$@"
}
is_uint() { [[ $1 =~ ^[0-9]+$ ]]; }

mode=task
case "${1:-}" in
  collect | submit)
    mode=$1
    shift
    ;;
  task) shift ;;
esac
while (($# > 0)); do
  case "$1" in
    --threads)
      (($# >= 2)) || die "--threads needs a value"
      threads=$2
      shift 2
      ;;
    --threads=*)
      threads=${1#*=}
      shift
      ;;
    --results)
      (($# >= 2)) || die "--results needs a value"
      results=$2
      shift 2
      ;;
    --results=*)
      results=${1#*=}
      shift
      ;;
    --out)
      (($# >= 2)) || die "--out needs a value"
      out=$2
      shift 2
      ;;
    --out=*)
      out=${1#*=}
      shift
      ;;
    --range)
      (($# >= 2)) || die "--range needs a value"
      range=$2
      shift 2
      ;;
    --range=*)
      range=${1#*=}
      shift
      ;;
    --materials)
      (($# >= 2)) || die "--materials needs a value"
      materials=(--materials "$2")
      shift 2
      ;;
    --materials=*)
      materials=(--materials "${1#*=}")
      shift
      ;;
    -h | --help)
      sed -n '2,/^#SBATCH/{/^#SBATCH/d;s/^# \{0,1\}//;p}' "${BASH_SOURCE[0]}"
      exit 0
      ;;
    --)
      shift
      break
      ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *) break ;;
  esac
done
(($# >= 1)) || die "no study file given (usage: see --help)"
study=$1
shift
[[ -f $study ]] || die "study file '$study' not found (working directory: $PWD)"
[[ -z $threads ]] || { is_uint "$threads" && ((threads >= 1)); } ||
  die "--threads must be a whole number >= 1, got '$threads'"

study_abs=$(readlink -f -- "$study")
name=$(basename -- "$study_abs" .toml)
hash=$(printf '%s' "$study_abs" | sha256sum | cut -c1-10)
key="$name-$hash"
shard_root="$results/shards/$key"

case "$mode" in
  task)
    (($# == 0)) || die "unexpected arguments after the study file: $*"
    if [[ -z ${SLURM_ARRAY_TASK_ID:-} ]]; then
      die "SLURM_ARRAY_TASK_ID is not set: submit with 'sbatch --array=0-N ...', or set SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT (and _MIN, _MAX) by hand to test"
    fi
    id=$SLURM_ARRAY_TASK_ID
    is_uint "$id" || die "SLURM_ARRAY_TASK_ID must be a whole number, got '$id'"
    id=$((10#$id))
    if [[ -n $range ]]; then
      [[ $range =~ ^([0-9]+)-([0-9]+)$ ]] || die "--range must look like 0-15, got '$range'"
      min=$((10#${BASH_REMATCH[1]})) max=$((10#${BASH_REMATCH[2]}))
      ((min <= max)) || die "empty --range '$range'"
      count=$((max - min + 1))
      from="--range $range"
    else
      [[ -n ${SLURM_ARRAY_TASK_COUNT:-} ]] ||
        die "SLURM_ARRAY_TASK_COUNT is not set (Slurm sets it for job arrays; set it by hand to test)"
      count=$SLURM_ARRAY_TASK_COUNT
      min=${SLURM_ARRAY_TASK_MIN:-0}
      max=${SLURM_ARRAY_TASK_MAX:-$((min + count - 1))}
      for v in "$count" "$min" "$max"; do
        is_uint "$v" || die "Slurm array variables must be whole numbers (ID=$id MIN=$min MAX=$max COUNT=$count)"
      done
      count=$((10#$count)) min=$((10#$min)) max=$((10#$max))
      if ((max - min + 1 != count)); then
        die "the array must be a contiguous range like --array=0-$((count - 1)) or --array=1-$count: got MIN=$min MAX=$max COUNT=$count (stepped or sparse, e.g. 0-6:2 or 1,3,5). To rerun some tasks of an array, give the full range: sbatch --array=ID,... studies/slurm-array.sh --range FIRST-LAST STUDY.toml"
      fi
      from="the Slurm array $min-$max"
    fi
    index=$((id - min))
    ((index >= 0 && index < count)) || die "SLURM_ARRAY_TASK_ID=$id is outside $min..$max"
    if [[ -z $threads ]]; then
      if [[ -n ${SLURM_CPUS_PER_TASK:-} ]]; then
        threads=$SLURM_CPUS_PER_TASK
        src=SLURM_CPUS_PER_TASK
      else
        threads=$(nproc)
        src=nproc
      fi
      { is_uint "$threads" && ((threads >= 1)); } || die "bad thread count '$threads' from $src"
    else
      src="--threads"
    fi
    dir="$shard_root/shard-$index-of-$count"
    say "study $study_abs"
    say "array task $id of $min-$max (from $from): shard $index/$count, threads $threads (from $src), into $dir"
    say "host $(hostname), job ${SLURM_JOB_ID:-none}, started $(date -Is)"
    run "$magopt" "${materials[@]}" sweep "$study_abs" --shard "$index/$count" --threads "$threads" --out "$dir" --resume
    say "shard $index/$count done $(date -Is)"
    ;;

  collect)
    (($# <= 1)) || die "collect takes at most one shard count after the study file"
    if (($# == 1)); then
      { is_uint "$1" && ((10#$1 >= 1)); } || die "shard count must be a whole number >= 1, got '$1'"
      count=$((10#$1))
    else
      [[ -d $shard_root ]] || die "no shards of $study_abs under '$shard_root' (did the array run with --results '$results'?)"
      counts=$(find "$shard_root" -mindepth 1 -maxdepth 1 -type d -name 'shard-*-of-*' -printf '%f\n' |
        sed -n 's/^shard-[0-9]*-of-\([0-9]*\)$/\1/p' | sort -un)
      [[ -n $counts ]] || die "no shard directories in '$shard_root'"
      if [[ $(wc -l <<<"$counts") -ne 1 ]]; then
        die "'$shard_root' holds shards of different arrays (shard counts: $(tr '\n' ' ' <<<"$counts")): give the count, e.g. 'studies/slurm-array.sh collect $study N'"
      fi
      count=$counts
    fi
    dirs=()
    missing=()
    for ((i = 0; i < count; i++)); do
      d="$shard_root/shard-$i-of-$count"
      if [[ -f $d/study.toml ]]; then dirs+=("$d"); else missing+=("$d"); fi
    done
    if ((${#missing[@]} > 0)); then
      printf 'slurm-array.sh: error: %d of %d shard directories missing or empty:\n' "${#missing[@]}" "$count" >&2
      printf '  %s\n' "${missing[@]}" >&2
      printf 'slurm-array.sh: rerun the failed array tasks (finished runs are kept), then collect again\n' >&2
      exit 3
    fi
    out=${out:-$results/$key}
    say "collecting $count shards of $study_abs into $out"
    rc=0
    run "$magopt" "${materials[@]}" collect "${dirs[@]}" --out "$out" || rc=$?
    if ((rc != 0)); then
      printf 'slurm-array.sh: error: magopt collect exited %d (4: runs missing from the shards; rerun the failed tasks, then collect again)\n' "$rc" >&2
      exit "$rc"
    fi
    say "merged result in $out"
    ;;

  submit)
    (($# >= 1)) || die "submit needs an array range after the study file, e.g. 0-15"
    array=$1
    shift
    [[ $array =~ ^([0-9]+)-([0-9]+)(%[0-9]+)?$ ]] ||
      die "array range must be contiguous like 0-15 or 1-16 (optionally %K to throttle), got '$array'"
    ((10#${BASH_REMATCH[1]} <= 10#${BASH_REMATCH[2]})) || die "empty array range '$array'"
    command -v sbatch >/dev/null || die "sbatch not found"
    self=$(readlink -f -- "${BASH_SOURCE[0]}")
    results_abs=$(mkdir -p -- "$results" && cd -- "$results" && pwd -P)
    common=(--results "$results_abs" "${materials[@]}")
    task_args=("${common[@]}")
    [[ -z $threads ]] || task_args+=(--threads "$threads")
    collect_args=("${common[@]}")
    [[ -z $out ]] || collect_args+=(--out "$(readlink -f -- "$out")")
    # Options after ours would override them; ours come last for the collect job's CPU count.
    jid=$(run sbatch --parsable --job-name="magopt-$name" --array="$array" "$@" \
      "$self" "${task_args[@]}" "$study_abs")
    jid=${jid%%;*}
    is_uint "$jid" || die "could not read the job id from sbatch (got '$jid')"
    say "array job $jid ($array)"
    cid=$(run sbatch --parsable --job-name="magopt-$name-collect" "$@" --ntasks=1 --cpus-per-task=1 \
      --dependency="afterok:$jid" --kill-on-invalid-dep=yes \
      "$self" collect "${collect_args[@]}" "$study_abs")
    cid=${cid%%;*}
    is_uint "$cid" || die "could not read the job id of the collect job from sbatch (got '$cid')"
    say "collect job $cid (runs after every task of $jid succeeded; cancelled if one fails)"
    say "shards: $results_abs/shards/$key; result: ${out:-$results_abs/$key}"
    printf '%s %s\n' "$jid" "$cid"
    ;;
esac
