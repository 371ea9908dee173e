#!/usr/bin/env bash
# The align model against E&B 2020 (docs/align.md), claim by claim: runs every case of
# results/reproduction/align.md and renders the report (studies/report-align.sh).
# Usage (from the repository root):
#   bash studies/reproduce-align.sh          # full: N = 1000, 4 replicates, the source's grids
#                                            # (§3, Figs. 6–7): 1512 runs, about 1.5 h on 2 cores
#   bash studies/reproduce-align.sh --quick  # CI size: N = 150, one replicate, coarser grids
#                                            # (236 runs, about 2 min on 2 cores)
#   RELEASE=inertial bash studies/reproduce-align.sh --quick
#                                            # every DEM run with --release-scheme inertial (the
#                                            # default until 2026-12-03; docs/align.md, "The
#                                            # release"), into align-runs-quick-inertial/,
#                                            # align-quick-inertial.md
# Runs land in results/reproduction/align-runs[-quick]/<case>-s<seed>.json (the `magopt align
# --json` record of each run); the report goes to results/reproduction/align[-quick].md. Cases
# already recorded are kept (delete the directory to start over), so an interrupted run resumes.
# Each settled packing is kept in <runs>/packings/ (not committed) and reused by every case of its
# seed and settling and release schemes (`magopt align --packing-cache`: the same bits).
# CASES=REGEX runs only the cases whose name matches (a partial run: the report shows the
# others as –), e.g. CASES='^(default|source)-mu.*-h40$' for Fig. 6b at full size.
# JOBS=K runs K cases at a time, one thread each (default: the number of cores); each study's
# wall-clock time is appended to <runs>/timing.tsv (study, runs, seconds, cores, JOBS).
set -euo pipefail
mode=${1:-full}
bin=${MAGOPT:-target/release/magopt}
[ -x "$bin" ] || cargo build --release --locked
if [ "$mode" = "--quick" ]; then
  suffix=-quick; n=150; seeds="1"; fields="10 20 31 40 60 100"; frictions="0 0.2 0.5"
  limit_time=2000s
else
  suffix=; n=1000; seeds="1 2 3 4"; fields="5 10 20 31 40 60 80 100"; frictions="0 0.1 0.2 0.3 0.5"
  limit_time=20000s
fi
pressures="0 0.5 1 5 10"
release=${RELEASE:-overdamped}
[ "$release" = overdamped ] || suffix=$suffix-$release
out=results/reproduction/align-runs$suffix
mkdir -p "$out"
printf 'fields="%s"\nfrictions="%s"\npressures="%s"\nseeds="%s"\nlimit_time=%s\nrelease="%s"\ncpu="%s"\n' \
  "$fields" "$frictions" "$pressures" "$seeds" "$limit_time" "$release" \
  "$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)" > "$out/grid.env"
jobs=${JOBS:-$(nproc)}
queue=$(mktemp); trap 'rm -f "$queue"' EXIT
# run CASE ARG…: queue one run per seed, recorded as CASE-s<seed>.json (see `study`)
run() {
  local name=$1 s; shift
  [[ $name =~ ${CASES:-.} ]] || return 0
  for s in $seeds; do
    [ -s "$out/$name-s$s.json" ] || echo "$name $s $*" >> "$queue"
  done
}
# one CASE SEED ARG…: a single run; a run that ends "not reached" (exit 3) is a result too
one() {
  local name=$1 s=$2 rc=0; shift 2
  RAYON_NUM_THREADS=1 nice -n 10 "$bin" align --json --particles "$n" --seed "$s" \
    --max-time "$limit_time" --release-scheme "$release" \
    --packing-cache "$out/packings" "$@" \
    > "$out/$name-s$s.json.part" || rc=$?
  if [ "$rc" -le 3 ] && [ -s "$out/$name-s$s.json.part" ]; then
    mv "$out/$name-s$s.json.part" "$out/$name-s$s.json"
  else echo "$name seed $s: exit $rc (kept as .part)" >&2; fi
}
export -f one; export bin n out limit_time release
# study NAME: run the queued runs, JOBS at a time, and record the study's wall-clock time
study() {
  local k t0; k=$(wc -l < "$queue"); [ "$k" -gt 0 ] || return 0
  t0=$(date +%s.%N)
  xargs -P "$jobs" -L 1 bash -c 'one "$@"' _ < "$queue"
  awk -v s="$1" -v k="$k" -v t0="$t0" -v t1="$(date +%s.%N)" -v c="$(nproc)" -v j="$jobs" \
    'BEGIN { printf "%s\t%d\t%.0f\t%d\t%d\n", s, k, t1 - t0, c, j }' >> "$out/timing.tsv"
  : > "$queue"
}
# link RUN CASE: record the case RUN as CASE too (the same command), for each seed where RUN ran
link() {
  local s
  for s in $seeds; do [ ! -s "$out/$1-s$s.json" ] || ln -sf "$1-s$s.json" "$out/$2-s$s.json"; done
}
# the three methods: magopt's default (implicit regularized friction, exposed-layer load), the
# source's (its explicit Eq. (8), its top-layer load rule) and the Coulomb limit (v_ε = 0)
declare -A method=([default]="" [source]="--friction-scheme source-explicit --pressure-mode source-layer"
  [limit]="--friction-scheme coulomb-limit --max-sweeps 2000")

# §3, Fig. 6a: τ_0.95 versus H for each μ at 0.5 atm; the μ = 0 reference of the lone particles
for h in $fields; do
  [ -s "$out/ensemble-h$h-s1.json" ] ||
    "$bin" align --json --model ensemble --particles $n --field $h > "$out/ensemble-h$h-s1.json"
  for mu in $frictions; do
    for k in default source; do run $k-mu$mu-h$h --field $h --friction $mu ${method[$k]}; done
  done
done
study fig6a
# docs/align.md, "The ≈ 40 kOe question": each candidate difference alone, at μ = 0.2, over H
declare -A candidate=([source-layer]="--pressure-mode source-layer" [punch]="--pressure-mode punch"
  [source-explicit]="--friction-scheme source-explicit" [coulomb-limit]="${method[limit]}"
  [metastable]="--moment-branch metastable" [monodisperse]="--diameter-sigma 0"
  [half-step]="--rotation-step 0.025")
for c in "${!candidate[@]}"; do
  for h in $fields; do run cand-$c-h$h --field $h --friction 0.2 ${candidate[$c]}; done
done
study candidates
# Fig. 6a in the other two load modes, default friction (μ = 0.2: the candidates' runs, linked)
for pm in punch source-layer; do
  for mu in $frictions; do
    for h in $fields; do
      if [ "$mu" = 0.2 ]; then link cand-$pm-h$h pm$pm-mu0.2-h$h
      else run pm$pm-mu$mu-h$h --field $h --friction $mu --pressure-mode $pm; fi
    done
  done
done
study fig6a-modes
# the source's settling (overdamped drop) makes a packing about 40× slower than FIRE: one sweep
# over the fields makes each seed's packing once (the study runner caches packings per seed)
# where one `magopt align` per field would make it eight times; each run record becomes a case
dropped() {
  local h s missing=0 tmp
  [[ cand-source-dropped =~ ${CASES:-.} ]] || return 0
  for h in $fields; do for s in $seeds; do
    [ -s "$out/cand-source-dropped-h$h-s$s.json" ] || missing=1
  done; done
  [ $missing = 1 ] || return 0
  tmp=$(mktemp -d)
  printf 'name = "cand-source-dropped"\nmodel = "align"\nreplicates = %s\nseed = %s\n' \
    "$(wc -w <<< "$seeds")" "${seeds%% *}" > "$tmp/study.toml"
  printf '[base]\nparticles = %s\nfriction = 0.2\nmax_time = "%s"\n' "$n" "$limit_time" \
    >> "$tmp/study.toml"
  printf 'settling_scheme = "source-dropped"\n[sweep]\nfield = [%s]\n' \
    "$(printf '"%skOe", ' $fields | sed 's/, $//')" >> "$tmp/study.toml"
  local t0; t0=$(date +%s.%N)
  nice -n 10 "$bin" sweep "$tmp/study.toml" --out "$tmp/out" > /dev/null
  for f in "$tmp"/out/runs/*.json; do
    h=$(jq '.values[0] / (1e6 / (4 * 3.141592653589793)) | round' "$f")
    s=$(jq .seed "$f")
    jq --argjson h "$h" --argjson n "$n" '(.result.metrics | map({(.[0]): .[1]}) | add) + {
      status: .result.status, reason: .result.reason, wall_time_s: .result.wall_time_s, seed,
      magopt_version, code, parameters: {field_kOe: $h, friction: 0.2, particles: $n,
      settling_scheme: "source-dropped"}}' "$f" > "$out/cand-source-dropped-h$h-s$s.json"
  done
  awk -v k="$(ls "$tmp"/out/runs | wc -l)" -v t0="$t0" -v t1="$(date +%s.%N)" -v c="$(nproc)" \
    'BEGIN { printf "candidates\t%d\t%.0f\t%d\t%d\n", k, t1 - t0, c, c }' >> "$out/timing.tsv"
  rm -rf "$tmp"
}
dropped
# §3, Fig. 7b: τ_0.95 versus P at μ = 0.05, 40 kOe, in every pressure mode and method
for p in $pressures; do
  for pm in exposed-layer punch source-layer; do
    run pm$pm-p$p --field 40 --friction 0.05 --pressure $p --pressure-mode $pm
  done
  run source-p$p --field 40 --friction 0.05 --pressure $p ${method[source]}
done
study fig7b
# §3, Fig. 7a: τ_0.95 versus H for each P at μ = 0.05, default friction in each load mode and
# the source's method; its 40 kOe points are Fig. 7b's runs (linked, not rerun)
for p in $pressures; do
  for h in $fields; do
    for pm in exposed-layer punch source-layer; do
      if [ "$h" = 40 ]; then link pm$pm-p$p fig7a-$pm-p$p-h40
      else run fig7a-$pm-p$p-h$h --field $h --friction 0.05 --pressure $p --pressure-mode $pm; fi
    done
    if [ "$h" = 40 ]; then link source-p$p fig7a-source-p$p-h40
    else run fig7a-source-p$p-h$h --field $h --friction 0.05 --pressure $p ${method[source]}; fi
  done
done
study fig7a
# the Coulomb limit last: where friction holds the particles it creeps to the time limit
for mu in $frictions; do run limit-mu$mu-h40 --field 40 --friction $mu ${method[limit]}; done
study fig6b-limit
for p in $pressures; do run limit-p$p --field 40 --friction 0.05 --pressure $p ${method[limit]}; done
study fig7b-limit
bash studies/report-align.sh "$out" > "results/reproduction/align$suffix.md"
