#!/usr/bin/env python3
"""Paired-seed differences between two codes of the align release.

Reads results/bench/released-bed/local-corrections.csv (one row per N, seed and code, written
from `magopt align --particles N --seed s --json` on 2 threads) and prints, for every seed both
codes ran, the mean difference NEW - OLD of each packing and alignment observable with its
standard error, over all seeds and per block of 24 seeds.

    python3 bench/paired-seeds.py vec32 spring16 [N]
"""

import csv
import statistics
import sys
from pathlib import Path

TABLE = Path(__file__).parent.parent / "results/bench/released-bed/local-corrections.csv"
OBSERVABLES = ["tau_095_s", "tau_090_s", "contacts", "packing_fraction", "sticking_fraction"]
BLOCK = 24


def rows(code, n):
    with open(TABLE) as f:
        return {int(r["seed"]): r for r in csv.DictReader(f) if r["code"] == code and r["N"] == n}


def report(new, old, seeds, label):
    print(f"{label}: {len(seeds)} seeds")
    for name in OBSERVABLES:
        d = [float(new[s][name]) - float(old[s][name]) for s in seeds]
        mean, se = statistics.mean(d), statistics.stdev(d) / len(d) ** 0.5
        print(f"  {name:18} {mean:+.3g} ± {se:.2g}  ({abs(mean) / se:.2f} standard errors)")


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    n = sys.argv[3] if len(sys.argv) == 4 else "10000"
    new, old = rows(sys.argv[1], n), rows(sys.argv[2], n)
    seeds = sorted(set(new) & set(old))
    if len(seeds) < 2:
        sys.exit(f"fewer than two seeds ran both {sys.argv[1]} and {sys.argv[2]} at N = {n}")
    report(new, old, seeds, f"{sys.argv[1]} - {sys.argv[2]}, N = {n}")
    for start in range(0, len(seeds), BLOCK):
        block = seeds[start : start + BLOCK]
        if len(block) > 1 and len(block) < len(seeds):
            report(new, old, block, f"seeds {block[0]}-{block[-1]}")


if __name__ == "__main__":
    main()
