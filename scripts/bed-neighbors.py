#!/usr/bin/env python3
"""Errors of the bed's neighbour modes against exact sums (results/bed/README.md, "Neighbour
lists against exact sums").

Usage: python3 scripts/bed-neighbors.py DIR
DIR holds the output directories of `magopt sweep studies/bed-neighbors-<kind>.toml` for
kind = exact, lists, mts and (if present) tree; each one's runs.parquet is read (needs
pyarrow). Every study uses seed 1 and the same speed, so each run is compared with the exact
run of the same N. Prints Markdown tables: the exact runs; F_max and cycle-work errors of the
cut-off lists (Verlet, r_v = 11.26 D); the tree's errors; multiple time stepping against
K = 1; wall time as a fraction of the exact run's.
"""
import os
import sys


def rows(directory, kind):
    """The ok runs of one study as dicts, or [] if the study is absent."""
    path = os.path.join(directory, f"bed-neighbors-{kind}", "runs.parquet")
    if not os.path.exists(path):
        return []
    import pyarrow.parquet as pq

    table = pq.read_table(path).to_pydict()
    runs = [dict(zip(table, values)) for values in zip(*table.values())]
    return [r for r in runs if r["status"] == "ok"]


def pct(value, reference):
    return f"{100.0 * (value / reference - 1.0):+.1f} %"


def errors(run, exact):
    return (pct(run["max_piston_force_N"], exact["max_piston_force_N"]) + ", "
            + pct(run["cycle_work_J"], exact["cycle_work_J"]))


def main(directory):
    exact = {int(r["particles"]): r for r in rows(directory, "exact")}
    sizes = sorted(exact)
    print("| N | exact F_max (N) | exact cycle work (J) | exact wall (s) | steps |")
    print("|---|---|---|---|---|")
    for n in sizes:
        r = exact[n]
        print(f"| {n} | {r['max_piston_force_N']:.2f} | {r['cycle_work_J']:.3f} | "
              f"{r['wall_time_s']:.0f} | {r['steps']} |")

    lists = rows(directory, "lists")
    cutoffs = sorted({r["cutoff"] for r in lists})
    pick = lambda n, rc: next(
        (r for r in lists if int(r["particles"]) == n and r["cutoff"] == rc
         and r["neighbors"] == "verlet" and r["list_radius"] == 11.26), None)
    print()
    print("| N | " + " | ".join(f"r_c = {rc:g} D: F_max, work" for rc in cutoffs) + " |")
    print("|---|" + "---|" * len(cutoffs))
    for n in sizes:
        cells = [pick(n, rc) for rc in cutoffs]
        print(f"| {n} | " + " | ".join(errors(c, exact[n]) if c else "–" for c in cells) + " |")

    tree = rows(directory, "tree")
    if tree:
        variants = sorted({(r["opening_angle"], r["far_field_interval"]) for r in tree},
                          key=lambda v: (-v[0], v[1]))
        print()
        print("| N | " + " | ".join(f"tree θ = {t:g}, K = {k}: F_max, work" for t, k in variants)
              + " |")
        print("|---|" + "---|" * len(variants))
        for n in sizes:
            cells = [next((r for r in tree if int(r["particles"]) == n
                           and (r["opening_angle"], r["far_field_interval"]) == v), None)
                     for v in variants]
            print(f"| {n} | " + " | ".join(errors(c, exact[n]) if c else "–" for c in cells)
                  + " |")

    mts = rows(directory, "mts")
    intervals = sorted({int(r["far_field_interval"]) for r in mts})
    base = {int(r["particles"]): r for r in mts if int(r["far_field_interval"]) == 1}
    print()
    print("| N | " + " | ".join(f"K = {k}: F_max, work against K = 1" for k in intervals[1:])
          + " |")
    print("|---|" + "---|" * (len(intervals) - 1))
    for n in sizes:
        cells = [next((r for r in mts if int(r["particles"]) == n
                       and int(r["far_field_interval"]) == k), None) for k in intervals[1:]]
        print(f"| {n} | " + " | ".join(errors(c, base[n]) if c and n in base else "–"
                                       for c in cells) + " |")

    print()
    columns = [("cells", "lists", lambda r: r["neighbors"] == "cells" and r["list_radius"] == 11.26),
               ("Verlet r_v = 11.26 D", "lists", lambda r: r["neighbors"] == "verlet" and r["list_radius"] == 11.26),
               ("Verlet r_v = 14 D", "lists", lambda r: r["neighbors"] == "verlet" and r["list_radius"] == 14.0),
               ("Verlet r_v = 8 D", "mts", lambda r: int(r["far_field_interval"]) == 1),
               ("r_v = 8 D, K = 4", "mts", lambda r: int(r["far_field_interval"]) == 4)]
    if tree:
        columns.append(("tree θ = 0.3, K = 4", "tree",
                        lambda r: r["opening_angle"] == 0.3 and int(r["far_field_interval"]) == 4))
    studies = {"lists": lists, "mts": mts, "tree": tree}
    print("| N | " + " | ".join(c[0] for c in columns) + " |")
    print("|---|" + "---|" * len(columns))
    for n in sizes:
        out = []
        for _, study, keep in columns:
            run = next((r for r in studies[study] if int(r["particles"]) == n
                        and keep(r) and r["cutoff"] == 7.13), None)
            out.append(f"{run['wall_time_s'] / exact[n]['wall_time_s']:.2f}" if run else "–")
        print(f"| {n} | " + " | ".join(out) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
