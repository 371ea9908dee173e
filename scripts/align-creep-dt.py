#!/usr/bin/env python3
"""Tables of the creep points against the time step (studies/align-creep-dt.sh).

Usage: python3 scripts/align-creep-dt.py DIR
DIR holds one output directory per case (<point>-rs<rotation step>-tol<solver tolerance>);
each one's series.parquet (A(t)) and runs.parquet are read (needs pyarrow). Prints Markdown:
per case the time step, A at 50, 100, 200, 300 and 400 s, τ_0.90 and τ_0.95 read off the
series (linear interpolation between samples; "never" if A stays below), then the mean and
sample standard deviation of τ_0.95 over the runs with dt ≤ 0.13 s of each point.
"""
import math
import os
import sys


def read(case):
    import pyarrow.parquet as pq

    series = pq.read_table(os.path.join(case, "series.parquet")).to_pydict()
    pairs = [
        (t, a)
        for t, a, o in zip(series["time_s"], series["value"], series["observable"])
        if o == "alignment"
    ]
    run = pq.read_table(os.path.join(case, "runs.parquet")).to_pydict()
    return pairs, run["time_step_s"][0]


def value_at(pairs, time):
    for (t0, a0), (t1, a1) in zip(pairs, pairs[1:]):
        if t1 >= time:
            return a0 + (a1 - a0) * (time - t0) / (t1 - t0)
    return pairs[-1][1]


def crossing(pairs, level):
    for (t0, a0), (t1, a1) in zip(pairs, pairs[1:]):
        if a1 >= level:
            return t0 + (t1 - t0) * (level - a0) / (a1 - a0)
    return None


def fmt(x):
    return "never" if x is None else f"{x:.1f}"


def main(directory):
    cases = sorted(
        (c for c in os.listdir(directory) if "-rs" in c),
        key=lambda c: (c.split("-rs")[0], -float(c.split("-rs")[1].split("-tol")[0]), c),
    )
    print("| point | rotation step (rad) | solver tol | dt (s) | A(50 s) | A(100 s) | A(200 s) "
          "| A(300 s) | A(400 s) | τ_0.90 (s) | τ_0.95 (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    fine = {}
    for case in cases:
        point, rest = case.split("-rs")
        step, tol = rest.split("-tol")
        pairs, dt = read(os.path.join(directory, case))
        a = [value_at(pairs, t) for t in (50, 100, 200, 300, 400)]
        t90, t95 = crossing(pairs, 0.90), crossing(pairs, 0.95)
        print(f"| {point} | {step} | {tol} | {dt:.4f} | "
              + " | ".join(f"{x:.4f}" for x in a) + f" | {fmt(t90)} | {fmt(t95)} |")
        if dt <= 0.13:
            fine.setdefault(point, []).append(t95)
    print()
    for point, taus in fine.items():
        reached = [t for t in taus if t is not None]
        if len(reached) < len(taus):
            print(f"- {point}, dt ≤ 0.13 s: {len(taus) - len(reached)} of {len(taus)} runs never reach 0.95")
        if len(reached) > 1:
            m = sum(reached) / len(reached)
            sd = math.sqrt(sum((t - m) ** 2 for t in reached) / (len(reached) - 1))
            print(f"- {point}, dt ≤ 0.13 s: τ_0.95 = {m:.0f} ± {sd:.0f} s (mean ± sd of "
                  f"{len(reached)} runs, range {min(reached):.0f}–{max(reached):.0f} s)")


if __name__ == "__main__":
    main(sys.argv[1])
