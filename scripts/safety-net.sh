#!/usr/bin/env bash
# Safety net of refactors: runs a sample of shipped results (the headline search, one bed cycle,
# one damper run, one blast run, one quick study) and compares every metric, bit for bit, with
# the values recorded in scripts/safety-net/ (written by `--record` with the code before the
# refactor). Wall-clock fields are ignored. Usage:
#   scripts/safety-net.sh [--record] [--quick]   (--quick skips the 1–4 min headline search)
set -euo pipefail
cd "$(dirname "$0")/.."
record=0; quick=0
for a in "$@"; do
  case "$a" in
    --record) record=1 ;;
    --quick) quick=1 ;;
    *) echo "unknown option $a" >&2; exit 2 ;;
  esac
done
# MAGOPT_BIN: a binary built elsewhere (e.g. from the commit before a refactor, to record)
bin=${MAGOPT_BIN:-target/release/magopt}
[ -n "${MAGOPT_BIN:-}" ] || cargo build --release --locked --quiet
expected=scripts/safety-net
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Every numeric leaf as "key=value" (the leaf's own key, so a changed JSON layout still
# compares), wall-clock and version fields left out; sorted.
leaves() {
  jq -r '[paths(numbers) as $p | ($p | map(tostring) | .[-1] | select(test("^[0-9]+$") | not) // ($p | map(tostring) | join("."))) as $k
          | select($k | test("wall|elapsed") | not) | "\($k)=\(getpath($p))"] | .[]' | sort
}

run_case() { # name, command…
  local name=$1; shift
  # exit 3 (a run that did not reach its target) still prints its JSON
  "$@" > "$work/$name.json" || [ $? -eq 3 ]
  leaves < "$work/$name.json" > "$work/$name.txt"
}

# the cycles at the time-step factor they were recorded with (the default since 2026-12-05 is 0.4 with dry friction)
run_case bed $bin bed --tail-correction none --time-step-factor 0.2 --json
run_case bed-tail $bin bed --time-step-factor 0.2 --json
run_case damper $bin damper --particles 92 --damper-time 0.5s --tail-correction none --json \
  --out "$work/damper"
# the fit details moved from the JSON into damper_fits.json (absent in the recorded layout)
if [ -f "$work/damper/damper_fits.json" ]; then
  leaves < "$work/damper/damper_fits.json" | sort -m - "$work/damper.txt" -o "$work/damper.txt"
fi
run_case blast $bin blast --json
run_case align $bin align --field 31kOe --particles 300 --json
$bin sweep studies/quick/bed-initial-conditions.toml --out "$work/study" > /dev/null
for f in "$work"/study/runs/*.json; do
  echo "seed=$(jq .seed "$f") metrics=$(jq -c .result.metrics "$f") series=$(jq -c .result.series "$f" | sha256sum | cut -c1-16)"
done | sort > "$work/study.txt"
[ $quick -eq 1 ] || run_case headline $bin optimize-field --material srfe12o19 --json

status=0
for f in "$work"/*.txt; do
  name=$(basename "$f")
  if [ $record -eq 1 ]; then
    mkdir -p "$expected"; cp "$f" "$expected/$name"
  elif ! diff -q "$expected/$name" "$f" > /dev/null; then
    # a new layout may add values and rename keys (layout.txt); every recorded value must
    # still be there, unchanged
    missing=$(awk -v c="${name%.txt}" '
      FNR == NR { if ($1 == c) map[$2] = $3; next }
      { split($0, kv, "="); k = kv[1]; if (k in map) { if (map[k] == "-") next; k = map[k] }
        print k "=" substr($0, length(kv[1]) + 2) }' "$expected/layout.txt" "$expected/$name" \
      | sort | comm -23 - "$f" | head -5)
    if [ -n "$missing" ]; then
      echo "safety net: ${name%.txt} differs:"; echo "$missing"; status=1
    fi
  fi
done
[ $status -eq 0 ] && [ $record -eq 0 ] && echo "safety net: every recorded value reproduced bit for bit"
exit $status
