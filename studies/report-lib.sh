# Helpers shared by the report scripts (studies/report-*.sh); source it after setting $dir,
# the directory of the run records (`magopt <model> --json`, one <case>.json per run).

# m CASE METRIC [FORMAT]: a metric of a run, formatted (default 4 significant digits)
m() {
  local v
  v=$(jq -r ".$2" "$dir/$1.json")
  if [ "$v" = null ]; then echo "–"; else printf "${3:-%.4g}" "$v"; fi
}
# ratio A B: A / B to 4 significant digits
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.4g", a / b }'; }
# cmd_of MODEL "KEY …" CASE: `magopt MODEL key=value …` for the named parameters of a run
cmd_of() {
  echo "\`magopt $1 $(jq -r --arg keys "$2" '($keys | split(" ")) as $k | [.parameters | to_entries[] | select(.key as $x | $k | index($x)) | "\(.key)=\(.value)"] | join(" ")' "$dir/$3.json")\`"
}
