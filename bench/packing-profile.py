#!/usr/bin/env python3
"""Contact profiles of settled align packings (files of `magopt align --packing-cache DIR`).

Usage: python3 bench/packing-profile.py DIR/*.packing

For each packing: N, the die, the packing fraction, the contacts per particle (pairs whose
overlap is positive, the count `z_rel` of `magopt bench align`), and where they are:
- by depth below the bed's top (bins of 4 R_av), centres only;
- by distance from the nearest side wall (particles 4 R_av or more from the floor and the top);
- the overlap spectrum at the release's stop (contacts per particle with overlap above 1e-6,
  1e-7, 1e-8 R_av; near contacts with a gap below 1e-4 R_av);
- the 4-core: what is left after repeatedly removing particles with fewer than four
  contacts, walls counted (a bed with no rigid backbone leaves nothing).

The file layout is `src/models/align/dem/packing/store.rs` (`save`). Standard library only;
results/bench/README.md, "The released bed across N", is made with it.
"""
import collections
import math
import struct
import sys

HEADER = b"magopt packing 1\n"


def load(path):
    """Radii, centres and the die's sides of one packing file (lengths in R_av)."""
    data = open(path, "rb").read()
    if not data.startswith(HEADER):
        sys.exit(f"{path}: not a magopt packing file (header {data[:16]!r})")
    at = len(HEADER)
    key_length = struct.unpack_from("<Q", data, at)[0]
    at += 8 + key_length
    n = struct.unpack_from("<Q", data, at)[0]
    at += 8
    radius = struct.unpack_from(f"<{n}d", data, at)
    at += 8 * n
    flat = struct.unpack_from(f"<{3 * n}d", data, at)
    at += 24 * n + 32 * n  # centres, then orientations (unused)
    lx, ly = struct.unpack_from("<2d", data, at)
    centres = [flat[3 * i : 3 * i + 3] for i in range(n)]
    return radius, centres, lx, ly


def pairs_within(radius, centres, margin):
    """Every pair (i, j, overlap) whose gap is below `margin` (cells of 2 R_max)."""
    cell = 2 * max(radius) + margin
    grid = collections.defaultdict(list)
    for i, (x, y, z) in enumerate(centres):
        grid[(int(x // cell), int(y // cell), int(z // cell))].append(i)
    for (cx, cy, cz), members in grid.items():
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in grid.get((cx + dx, cy + dy, cz + dz), ()):
                        for i in members:
                            if j <= i:
                                continue
                            d = math.dist(centres[i], centres[j])
                            overlap = radius[i] + radius[j] - d
                            if overlap > -margin:
                                yield i, j, overlap


def four_core(n, neighbours, walls):
    """Particles left after peeling those with fewer than 4 contacts (walls counted)."""
    alive = [True] * n
    degree = [len(neighbours[i]) + walls[i] for i in range(n)]
    stack = [i for i in range(n) if degree[i] < 4]
    while stack:
        i = stack.pop()
        if not alive[i]:
            continue
        alive[i] = False
        for j in neighbours[i]:
            if alive[j]:
                degree[j] -= 1
                if degree[j] < 4:
                    stack.append(j)
    return sum(alive)


def profile(path):
    radius, centres, lx, ly = load(path)
    n = len(radius)
    near = list(pairs_within(radius, centres, 1e-4))
    touching = [(i, j, o) for i, j, o in near if o > 0]
    neighbours = [[] for _ in range(n)]
    for i, j, _ in touching:
        neighbours[i].append(j)
        neighbours[j].append(i)
    degree = [len(x) for x in neighbours]
    top = max(c[2] + r for c, r in zip(centres, radius))
    solid = sum(4 / 3 * math.pi * r**3 for r in radius)
    print(f"{path}: N = {n}, die {lx:.1f} x {ly:.1f} R_av, top {top:.1f} R_av, "
          f"phi {solid / (lx * ly * top):.4f}, contacts per particle {2 * len(touching) / n:.3f}")

    def table(title, key, bins):
        sums = collections.defaultdict(lambda: [0, 0])
        for i, c in enumerate(centres):
            k = key(c)
            if k is not None:
                sums[k][0] += degree[i]
                sums[k][1] += 1
        print(f"  {title}: " + ", ".join(
            f"{bins(k)} {s / c:.2f} ({c})" for k, (s, c) in sorted(sums.items())))

    table("contacts by depth below the top (R_av: z (particles))",
          lambda c: int((top - c[2]) // 4), lambda k: f"{4 * k}-{4 * k + 4}")
    edges = [0, 2, 4, 6, 8, 12, 16, 24, 32, 1e9]

    def wall_zone(c):
        if c[2] < 4 or c[2] > top - 4:
            return None
        w = min(c[0], lx - c[0], c[1], ly - c[1])
        return next(k for k in range(len(edges) - 1) if w < edges[k + 1])

    table("contacts by distance from the side walls (R_av; 4 R_av from floor and top)",
          wall_zone, lambda k: f"{edges[k]}-{edges[k + 1] if edges[k + 1] < 1e9 else 'inf'}")
    above = {t: 2 * sum(1 for _, _, o in touching if o > t) / n for t in (1e-6, 1e-7, 1e-8)}
    gaps = 2 * sum(1 for _, _, o in near if o <= 0) / n
    overlaps = sorted(o for _, _, o in touching)
    print("  overlap spectrum: contacts per particle above 1e-6 / 1e-7 / 1e-8 R_av "
          + " / ".join(f"{v:.3f}" for v in above.values())
          + f"; gaps below 1e-4 R_av {gaps:.3f} per particle; median overlap "
          f"{overlaps[len(overlaps) // 2]:.2e}, largest {overlaps[-1]:.2e}")
    walls = [int(c[2] < r) + int(c[0] < r) + int(lx - c[0] < r) + int(c[1] < r)
             + int(ly - c[1] < r) for c, r in zip(centres, radius)]
    print(f"  4-core: {four_core(n, neighbours, walls) / n:.3f} of the particles")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for name in sys.argv[1:]:
        try:
            profile(name)
        except (OSError, struct.error, ValueError) as error:
            sys.exit(f"{name}: not a readable magopt packing file ({error})")
