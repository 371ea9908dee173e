"""runs.csv from the JSON records of run.sh (argument: their folder; or runs.csv itself, to
print the table from the shipped file), then the paired
differences from the reference of the same N, speed and seed on standard error:
exact sums at factor 0.2 for the cycles (the list with the tail at factor 0.2 where no exact
run was made: N = 736 and 1472 at the standard speed; the tail at factor 0.4 at N = 4416, where
neither was run; the cycles without dry friction against their own factor 0.2), factor 0.2 for
the damper. A failed run (status not ok) is listed in
runs.csv and left out of the differences."""
import csv, glob, json, os, re, statistics as st, sys
from collections import defaultdict

source = sys.argv[1] if len(sys.argv) > 1 else "json"
rows = []
if source.endswith(".csv"):
    # the shipped table alone (its JSON records are not kept): numbers back from text
    for r in csv.DictReader(open(source)):
        rows.append({k: (v if k in ("set", "label", "status") else float(v) if v else None)
                     for k, v in r.items()})
        rows[-1]["n"], rows[-1]["seed"] = int(rows[-1]["n"]), int(rows[-1]["seed"])
paths = [] if source.endswith(".csv") else sorted(glob.glob(os.path.join(source, "*.json")))
for path in paths:
    name = os.path.basename(path)[:-5]
    j = json.load(open(path))
    m = re.match(r"damper-f([\d.]+)-s(\d+)$", name)
    if m:
        rows.append(dict(set="damper", n=368, label="f" + m[1], seed=int(m[2]), status=j["status"],
                         fall_alpha=j["damper_fall_vdp_alpha"], fall_omega=j["damper_fall_vdp_omega"],
                         steps=j["steps"], wall_s=j["wall_time_s"]))
        continue
    m = re.match(r"(fast|std)-N(\d+)-(\w+)-s(\d+)$", name)
    rows.append(dict(set=m[1], n=int(m[2]), label=m[3], seed=int(m[4]), status=j["status"],
                     max_piston_force_N=j["max_piston_force_N"], cycle_work_J=j["cycle_work_J"],
                     steps=j["steps"], wall_s=j["wall_time_s"]))
fields = ["set", "n", "label", "seed", "status", "max_piston_force_N", "cycle_work_J",
          "fall_alpha", "fall_omega", "steps", "wall_s"]
w = csv.DictWriter(sys.stdout, fields, lineterminator="\n")
w.writeheader()
for r in rows:
    w.writerow(r)

def paired(rows, keys, refs, relative):
    """Paired differences of every run from its reference: the first of `refs` the same set,
    N and seed has, and for the cycles without dry friction (labels none…, visc…) their own
    run at factor 0.2 (nonef2, viscf2)."""
    by = defaultdict(dict)
    for r in rows:
        by[(r["set"], r["n"], r["seed"])][r["label"]] = r
    out = defaultdict(lambda: defaultdict(list))
    for (s, n, seed), labels in by.items():
        present = [r for r in refs if r in labels]
        for label, r in labels.items():
            own = label[:4] + "f2" if label[:4] in ("none", "visc") else (present or [None])[0]
            if own is None or label == own or own not in labels or r["status"] != "ok":
                continue
            ref = labels[own]
            for k in keys:
                out[(s, n, f"{label}/{own}")][k].append(100 * (r[k] / ref[k] - 1) if relative else r[k] - ref[k])
            out[(s, n, f"{label}/{own}")]["speed"].append(ref["wall_s"] / r["wall_s"])
    return out


def show(out, keys, unit):
    for (s, n, label), d in sorted(out.items()):
        k = len(d["speed"])
        if k < 2:
            continue
        text = "  ".join(f"{key} {st.mean(v):+.3f} ± {st.stdev(v) / k ** 0.5:.3f}{unit} (sd {st.stdev(v):.3f})"
                         for key, v in d.items() if key != "speed")
        print(f"{s:6s} N={n:<5d} {label:16s} seeds {k:2d}  {text}  time ×{1 / st.mean(d['speed']):.2f} of the reference",
              file=sys.stderr)

cycles = [r for r in rows if r["set"] != "damper"]
show(paired(cycles, ["max_piston_force_N", "cycle_work_J"], ["exact", "c713", "c713f4"], True), ["F", "W"], " %")
damper = [r for r in rows if r["set"] == "damper"]
show(paired(damper, ["fall_alpha", "fall_omega"], ["f0.2"], False), ["a", "w"], "")
