#!/usr/bin/env python3
"""Runs needed by grid, scan + Brent, Nelder–Mead and Bayesian optimization to reach the same
optimum of τ_0.95 on the align model (issue "Study kinds", item 7).

Problems (each method runs as a `magopt optimize` study into results/optimizers/<problem>-<method>/):
  ensemble-H  τ(H), non-interacting ensemble, 4 replicates
  dem-H       τ(H), DEM, N = 150, μ = 0.2, 0.5 atm, 2 replicates
  dem-HP      τ(H, P), DEM, N = 150, μ = 0.3, P in [0.1, 5] atm, 2 replicates

Criterion: τ* is the smallest replicate mean any method observed on the problem; a method
"reaches the optimum" at the first evaluated point whose replicate mean is within δ of τ*,
δ = max(1 % of τ*, 2 standard errors of the replicate mean at the τ* point). Runs = points ×
replicates (a grid of k points has no order: it needs all k). Common random numbers (the same
seeds at every point) make the means of different points comparable.

Usage: python3 scripts/compare-optimizers.py [--magopt PATH] [--only PROBLEM]
Writes results/optimizers/README.md (the table) and leaves each run's result directory.
Only the standard library is needed (it reads each optimum.json).
"""

import argparse
import json
import math
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "results" / "optimizers"

PROBLEMS = {
    "ensemble-H": {
        "base": 'material = "srfe12o19"\nmodel = "ensemble"\n',
        "replicates": 4,
        "parameters": '{ field = ["5kOe", "100kOe"] }',
        "grids": [5, 9, 17, 33],
    },
    "dem-H": {
        "base": 'material = "srfe12o19"\nparticles = 150\n',
        "replicates": 2,
        "parameters": '{ field = ["5kOe", "100kOe"] }',
        "grids": [5, 9, 17],
    },
    "dem-HP": {
        "base": 'material = "srfe12o19"\nparticles = 150\nfriction = 0.3\n',
        "replicates": 2,
        "parameters": '{ field = ["5kOe", "100kOe"], pressure = ["0.1atm", "5atm"] }',
        "grids": [3, 5],
    },
}


def methods(problem):
    """(label, [optimize] keys) per method; a grid is a log scan with one Brent step after it
    (only its first k points count)."""
    two = "pressure" in problem["parameters"]
    out = []
    if not two:
        out += [(f"grid-{k}", f"scan_points = {k}\niterations = 1\n") for k in problem["grids"]]
        out.append(("brent", "scan_points = 7\niterations = 8\n"))
    out.append(("nelder-mead", 'method = "nelder-mead"\niterations = 30\n'))
    out.append(("bayes", 'method = "bayes"\nbudget = 20\nbatch = 2\n'))
    return out


def study_text(name, problem, keys):
    return (
        f'name = "{name}"\nmodel = "align"\nreplicates = {problem["replicates"]}\nseed = 1\n'
        f'[base]\n{problem["base"]}'
        f'[optimize]\nparameters = {problem["parameters"]}\n'
        f'metric = "alignment_time_s"\n{keys}'
    )


def grid_text(name, problem, k):
    """A 2D grid as a sweep study: k log-spaced values per parameter."""
    return (
        f'name = "{name}"\nmodel = "align"\nreplicates = {problem["replicates"]}\nseed = 1\n'
        f'metrics = ["alignment_time_s"]\n[base]\n{problem["base"]}'
        f'[sweep]\nfield = {{ log = ["5kOe", "100kOe", {k}] }}\n'
        f'pressure = {{ log = ["0.1atm", "5atm", {k}] }}\n'
    )


KOE = 1e6 / (4 * math.pi)  # A/m per kOe
ATM = 101325.0  # Pa per atm


def run(magopt, args, directory):
    """Runs magopt; returns the summed wall time of the runs in `directory` (each run record
    keeps its own, so a re-run that reloads the runs reports the same)."""
    done = subprocess.run([magopt, *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"magopt {' '.join(args)} failed: {done.stderr.strip()}")
    return sum(
        json.loads(p.read_text())["result"].get("wall_time_s", 0.0)
        for p in (directory / "runs").glob("*.json")
    )


def points_of(directory):
    """Per evaluated point in order: (parameters, mean, std, replicates)."""
    summary = json.loads((directory / "optimum.json").read_text())
    return [
        (e["parameters"], e["mean"], e["std"], e["replicates"])
        for e in summary["evaluations"]
    ], summary


def grid_points(directory):
    """A 2D grid's points from its saved run records, grouped by grid point."""
    groups, where = {}, {}
    for path in sorted((directory / "runs").glob("*.json")):
        record = json.loads(path.read_text())
        value = dict(record["result"]["metrics"]).get("alignment_time_s")
        groups.setdefault(record["point"], []).append(value)
        field, pressure = record["values"]  # SI: A/m, Pa
        where[record["point"]] = {"field_kOe": field / KOE, "pressure_atm": pressure / ATM}
    out = []
    for point in sorted(groups):
        v = groups[point]
        ok = [x for x in v if x is not None]
        mean = sum(ok) / len(ok) if len(ok) == len(v) else None
        std = (math.sqrt(sum((x - mean) ** 2 for x in ok) / (len(ok) - 1))
               if mean is not None and len(ok) > 1 else 0.0)
        out.append((where[point], mean, std, len(v)))
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--magopt", default=str(ROOT / "target" / "release" / "magopt"))
    parser.add_argument("--only")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    for pname, problem in PROBLEMS.items():
        if args.only and pname != args.only:
            continue
        results = {}
        for label, keys in methods(problem):
            directory = OUT / f"{pname}-{label}"
            study = OUT / f"{pname}-{label}.toml"
            study.write_text(study_text(f"{pname}-{label}", problem, keys))
            wall = run(args.magopt, ["optimize", str(study), "--out", str(directory)], directory)
            points, summary = points_of(directory)
            if label.startswith("grid-"):
                points = points[: int(label.split("-")[1])]
            results[label] = (points, summary, wall)
        if "pressure" in problem["parameters"]:
            for k in problem["grids"]:
                label = f"grid-{k}x{k}"
                directory = OUT / f"{pname}-{label}"
                study = OUT / f"{pname}-{label}.toml"
                study.write_text(grid_text(f"{pname}-{label}", problem, k))
                wall = run(args.magopt, ["sweep", str(study), "--out", str(directory), "--resume"],
                           directory)
                results[label] = (grid_points(directory), None, wall)
        best = min(
            (m, s, r) for pts, _, _ in results.values() for _, m, s, r in pts if m is not None
        )
        tau, std, reps = best
        delta = max(0.01 * tau, 2 * std / math.sqrt(reps))
        for label, (pts, summary, wall) in results.items():
            reached = next(
                (k + 1 for k, (_, m, _, _) in enumerate(pts) if m is not None and m <= tau + delta),
                None,
            )
            if label.startswith("grid") and reached is not None:
                reached = len(pts)  # a grid runs all its points before it knows its best
            found = min((m for _, m, _, _ in pts if m is not None), default=None)
            where = summary["optimum"] if summary else None
            if label.startswith("grid"):
                # a grid reports its best point (for a 1D grid the scan's, not the Brent step's)
                where = min((p for p in pts if p[1] is not None), key=lambda p: p[1])[0] or None
            rows.append((pname, label, len(pts), len(pts) * problem["replicates"],
                         reached, reached and reached * problem["replicates"], found, where,
                         tau, delta, wall))
        (OUT / f"rows-{pname}.json").write_text(json.dumps([r for r in rows if r[0] == pname]))
    # the table holds every problem run so far (one problem per invocation with --only)
    rows = [tuple(r) for p in PROBLEMS if (OUT / f"rows-{p}.json").is_file()
            for r in json.loads((OUT / f"rows-{p}.json").read_text())]
    lines = [
        "# Runs to the optimum: grid, scan + Brent, Nelder–Mead, Bayesian optimization",
        "",
        "Generated by `python3 scripts/compare-optimizers.py` (see its header for the problems",
        "and the criterion). τ* = the smallest replicate mean any method observed; a method",
        "reaches it at its first point within δ of τ* (δ = max(1 %, 2 standard errors)); a grid",
        "needs all its points. Run time: the sum of the runs' own wall times (one thread each)",
        "on the 2-core development machine, shared with other jobs while they ran (indicative).",
        "",
        "| problem | method | points | runs | points to τ* ± δ | runs to τ* ± δ | best τ (s) | reported optimum | τ* (s) | δ (s) | run time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        where = ", ".join(f"{k} {v:.3g}" for k, v in (r[7] or {}).items()) or "–"
        lines.append(
            f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4] or 'not reached'} | "
            f"{r[5] or 'not reached'} | {r[6]:.3f} | {where} | {r[8]:.3f} | {r[9]:.3f} | {r[10]:.0f} |"
        )
    (OUT / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
