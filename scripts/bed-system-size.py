#!/usr/bin/env python3
"""F_max against N from the bed system-size studies (results/bed/README.md, "System size").

Usage: python3 scripts/bed-system-size.py DRY_DIR [VISCOUS_DIR]
DRY_DIR and VISCOUS_DIR are output directories of `magopt sweep studies/bed-system-size.toml`
and `studies/bed-system-size-viscous.toml`; their runs.parquet is read (needs pyarrow).
Prints Markdown: F_max per N (seed mean, seed sd, local exponent to the next N),
least-squares fits of the seed means (power law in log-log, c*sqrt(N), a*N + b,
p*sqrt(N) + q*N) over N = 368-736 and over N >= 368, and the viscous-only comparison.
"""
import math
import os
import sys


def forces(directory):
    """{N: [F_max of each seed]} of the runs that finished ok, from the study's runs.parquet."""
    import pyarrow.parquet as pq

    table = pq.read_table(os.path.join(directory, "runs.parquet")).to_pydict()
    out = {}
    for n, status, f_max in zip(
        table["particles"], table["status"], table["max_piston_force_N"]
    ):
        if status == "ok" and f_max is not None:
            out.setdefault(int(n), []).append(f_max)
    return out


def mean_sd(xs):
    m = sum(xs) / len(xs)
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else 0.0
    return m, sd


def solve2(a11, a12, a22, b1, b2):
    det = a11 * a22 - a12 * a12
    return (b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det


def rms(residuals):
    return math.sqrt(sum(r * r for r in residuals) / len(residuals))


def power_law(ns, fs):
    """(exponent e, ln c) of the least-squares line ln f = e ln n + ln c."""
    x = [math.log(n) for n in ns]
    y = [math.log(f) for f in fs]
    return solve2(sum(v * v for v in x), sum(x), len(x), sum(u * v for u, v in zip(x, y)), sum(y))


def fits(ns, fs):
    """Markdown cells: power law, c sqrt(N), a N + b, p sqrt(N) + q N (each with its rms)."""
    k = len(ns)
    e, logc = power_law(ns, fs)
    power = [math.exp(logc) * n**e for n in ns]
    c = sum(math.sqrt(n) * f for n, f in zip(ns, fs)) / sum(ns)
    a, b = solve2(sum(n * n for n in ns), sum(ns), k, sum(n * f for n, f in zip(ns, fs)), sum(fs))
    p, q = solve2(
        sum(ns),
        sum(n**1.5 for n in ns),
        sum(n * n for n in ns),
        sum(math.sqrt(n) * f for n, f in zip(ns, fs)),
        sum(n * f for n, f in zip(ns, fs)),
    )
    res = lambda model: rms([f - g for f, g in zip(fs, model)])
    return [
        f"N^{e:.3f}, rms {res(power):.2f} N",
        f"{c:.3f}·√N, rms {res([c * math.sqrt(n) for n in ns]):.2f} N",
        f"{b:.2f} {a:+.4f} N, rms {res([a * n + b for n in ns]):.2f} N",
        f"{p:.3f}·√N {q:+.5f} N, rms {res([p * math.sqrt(n) + q * n for n in ns]):.2f} N",
    ]


def main():
    dry = forces(sys.argv[1])
    ns = sorted(dry)
    stats = {n: mean_sd(dry[n]) for n in ns}
    print("| N | " + " | ".join(str(n) for n in ns) + " |")
    print("|---|" + "---|" * len(ns))
    print("| F_max (N) | " + " | ".join(f"{stats[n][0]:.2f}" for n in ns) + " |")
    print("| seed sd (N) | " + " | ".join(f"{stats[n][1]:.2f}" for n in ns) + " |")
    print("| seeds | " + " | ".join(str(len(dry[n])) for n in ns) + " |")
    local = [
        f"{math.log(stats[b][0] / stats[a][0]) / math.log(b / a):.2f}" for a, b in zip(ns, ns[1:])
    ]
    print("| local exponent to the next N | " + " | ".join(local) + " | |")
    print()
    print("| range | power law | √N (one parameter) | a N + b (the source's form) | p√N + qN |")
    print("|---|---|---|---|---|")
    ranges = [(368, 736)] + ([(368, max(ns))] if max(ns) > 736 else [])
    for lo, hi in ranges:
        sel = [n for n in ns if lo <= n <= hi]
        if len(sel) >= 3:
            print(f"| {sel[0]}–{sel[-1]} | " + " | ".join(fits(sel, [stats[n][0] for n in sel])) + " |")
    if len(sys.argv) > 2:
        visc = {n: mean_sd(fs)[0] for n, fs in forces(sys.argv[2]).items()}
        both = [n for n in sorted(visc) if n in stats]
        excess = [stats[n][0] - visc[n] for n in both]
        print()
        print("| N | " + " | ".join(str(n) for n in both) + " |")
        print("|---|" + "---|" * len(both))
        print("| F_max, viscous only (N) | " + " | ".join(f"{visc[n]:.2f}" for n in both) + " |")
        print("| F_max, dry (N), from above | " + " | ".join(f"{stats[n][0]:.2f}" for n in both) + " |")
        print("| dry − viscous (N) | " + " | ".join(f"{d:.2f}" for d in excess) + " |")
        print("| (dry − viscous) / N (N per disc) | " + " | ".join(f"{d / n:.5f}" for d, n in zip(excess, both)) + " |")
        if len(both) >= 2:
            for label, values in [("viscous only", [visc[n] for n in both]), ("dry − viscous", excess)]:
                e, _ = power_law(both, values)
                print(f"\nExponent of {label} over N = {both[0]}–{both[-1]}: N^{e:.2f}.", end="")
            print()


if __name__ == "__main__":
    main()
