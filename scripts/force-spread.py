#!/usr/bin/env python3
"""Seed-to-seed spread of the piston force over the cycle (de Paula 2025, Fig. 3.3a inset).

Reads the series.parquet of a `bed` sweep over replicates (one grid point; every replicate
runs the same piston trajectory, so the records share their times) and prints one JSON
object: the largest sigma(F)/mean(F_max) over the compression and over the expansion, its
value at maximum compression, and sigma(F_max)/mean(F_max), where sigma is the sample
standard deviation across replicates at each recorded time. Compression runs from the first
record with stroke y_P >= 0 to the largest stroke; expansion follows.

Usage: python3 scripts/force-spread.py DIR   (DIR from `magopt sweep`; needs pyarrow)
"""
import json
import math
import sys

import pyarrow.parquet as pq


def by_replicate(table, observable):
    """{replicate: [(time, value), ...]} of one observable, time-ordered."""
    out = {}
    rows = table.to_pydict()
    for rep, obs, t, v in zip(rows["replicate"], rows["observable"], rows["time_s"], rows["value"]):
        if obs == observable:
            out.setdefault(rep, []).append((t, v))
    return {k: sorted(v) for k, v in out.items()}


def sample_sd(values):
    n = len(values)
    mean = sum(values) / n
    return math.sqrt(sum((x - mean) ** 2 for x in values) / (n - 1))


def main(directory):
    table = pq.read_table(f"{directory}/series.parquet")
    force = by_replicate(table, "piston_force")
    stroke = by_replicate(table, "stroke")
    reps = sorted(force)
    length = min(len(force[r]) for r in reps)
    f_max = [max(v for _, v in force[r]) for r in reps]
    mean_max = sum(f_max) / len(f_max)
    ys = [sum(stroke[r][k][1] for r in reps) / len(reps) for k in range(length)]
    start = next(k for k, y in enumerate(ys) if y >= 0.0)
    turn = max(range(start, length), key=lambda k: ys[k])
    spread = [sample_sd([force[r][k][1] for r in reps]) / mean_max for k in range(length)]
    print(json.dumps({
        "replicates": len(reps),
        "max_sigma_compression": max(spread[start:turn + 1]),
        "max_sigma_expansion": max(spread[turn:]),
        "sigma_at_max_compression": spread[turn],
        "sigma_fmax_over_mean": sample_sd(f_max) / mean_max,
        "mean_fmax_N": mean_max,
    }))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: force-spread.py DIR")
    main(sys.argv[1])
