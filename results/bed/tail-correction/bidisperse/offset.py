"""F_max and cycle work at N = 400, a = 0.5, R = 0 over the 40 starts (seeds 1-8, initial
velocities scaled by 1, 1.01, 0.99, 1.02 and 0.98): each method's mean and standard error, and its mean
paired difference from exact sums (results/bed/README.md, "Bi-disperse beds"). Run from this
folder after run.sh."""
import json
import math
import statistics as st

STARTS = [(v, s) for v in ("", "-v0.0101", "-v0.0099", "-v0.0102", "-v0.0098") for s in range(1, 9)]


def values(method, key):
    return [json.load(open(f"{method}{v}-n400-a0.5-R0-s{s}.json"))[key] for v, s in STARTS]


def mean_se(xs):
    return st.mean(xs), st.stdev(xs) / math.sqrt(len(xs))


for key in ("max_piston_force_N", "cycle_work_J"):
    exact = values("exact", key)
    m, se = mean_se(exact)
    print(f"{key}: exact {m:.4f} ± {se:.4f} (sd {100 * st.stdev(exact) / m:.2f} %)")
    for method in ("tail", "tree0.3", "list"):
        try:
            xs = values(method, key)
        except FileNotFoundError:
            continue
        mx, sx = mean_se(xs)
        d = mean_se([100 * (x - e) / e for x, e in zip(xs, exact)])
        print(f"  {method}: {mx:.4f} ± {sx:.4f} (sd {100 * st.stdev(xs) / mx:.2f} %);"
              f" paired from exact {d[0]:+.2f} ± {d[1]:.2f} %")
