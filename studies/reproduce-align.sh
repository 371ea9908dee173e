#!/usr/bin/env bash
# The align model against E&B 2020 (docs/align.md), claim by claim: runs every case of
# results/reproduction/align.md and renders the report (studies/report-align.sh).
# Usage (from the repository root):
#   bash studies/reproduce-align.sh          # full: N = 1000, 4 replicates, the source's grids
#                                            # (§3, Figs. 6–7): many CPU hours on 2 cores
#   bash studies/reproduce-align.sh --quick  # CI size: N = 150, one replicate, coarser grids
# Runs land in results/reproduction/align-runs[-quick]/<case>-s<seed>.json (the `magopt align
# --json` record of each run); the report goes to results/reproduction/align[-quick].md. Cases
# already recorded are kept (delete the directory to start over), so an interrupted run resumes.
# CASES=REGEX runs only the cases whose name matches (a partial run: the report shows the
# others as –), e.g. CASES='^(default|source)-mu.*-h40$' for Fig. 6b at full size.
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
out=results/reproduction/align-runs$suffix
mkdir -p "$out"
printf 'fields="%s"\nfrictions="%s"\npressures="%s"\nseeds="%s"\nlimit_time=%s\n' "$fields" \
  "$frictions" "$pressures" "$seeds" "$limit_time" > "$out/grid.env"
# run CASE ARG…: one run per seed, recorded as CASE-s<seed>.json
run() {
  local name=$1 s; shift
  [[ $name =~ ${CASES:-.} ]] || return 0
  for s in $seeds; do
    [ -s "$out/$name-s$s.json" ] && continue
    nice -n 10 "$bin" align --json --particles $n --seed $s --max-time $limit_time "$@" \
      > "$out/$name-s$s.json.part"
    mv "$out/$name-s$s.json.part" "$out/$name-s$s.json"
  done
}
# the three methods: magopt's default (implicit regularized friction, exposed-layer load), the
# source's (its explicit Eq. (8), its top-layer load rule) and the Coulomb limit (v_ε = 0)
declare -A method=([default]="" [source]="--friction-scheme source-explicit --pressure-mode source-layer"
  [limit]="--friction-scheme coulomb-limit --max-sweeps 2000")

# §3, Fig. 6a: τ_0.95 versus H for each μ at 0.5 atm; the μ = 0 reference of the lone particles
for h in $fields; do
  "$bin" align --json --model ensemble --particles $n --field $h > "$out/ensemble-h$h-s1.json"
  for mu in $frictions; do
    for k in default source; do run $k-mu$mu-h$h --field $h --friction $mu ${method[$k]}; done
  done
done
# §3, Fig. 6b: τ_0.95 versus μ at 40 kOe, also in the Coulomb limit
for mu in $frictions; do run limit-mu$mu-h40 --field 40 --friction $mu ${method[limit]}; done
# §3, Fig. 7b: τ_0.95 versus P at μ = 0.05, 40 kOe, in every pressure mode and method
for p in $pressures; do
  for pm in exposed-layer punch source-layer; do
    run pm$pm-p$p --field 40 --friction 0.05 --pressure $p --pressure-mode $pm
  done
  for k in source limit; do run $k-p$p --field 40 --friction 0.05 --pressure $p ${method[$k]}; done
done
# docs/align.md, "The ≈ 40 kOe question": each candidate difference alone, at μ = 0.2, over H
declare -A candidate=([source-layer]="--pressure-mode source-layer" [punch]="--pressure-mode punch"
  [source-explicit]="--friction-scheme source-explicit" [coulomb-limit]="${method[limit]}"
  [metastable]="--moment-branch metastable")
for c in "${!candidate[@]}"; do
  for h in $fields; do run cand-$c-h$h --field $h --friction 0.2 ${candidate[$c]}; done
done
bash studies/report-align.sh "$out" > "results/reproduction/align$suffix.md"
