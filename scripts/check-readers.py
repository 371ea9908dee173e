#!/usr/bin/env python3
"""Open magopt's particle files with the readers of the field and print PASS/FAIL lines.

Optional tooling: magopt neither needs nor calls this script. Usage:

    python3 scripts/check-readers.py DIR [DIR ...]

where each DIR is a magopt --out directory (with DIR/snapshots/). Every tool is optional: one
that is not installed is reported as SKIP. Install them (user space) with

    python3 -m venv /tmp/viewers-venv
    /tmp/viewers-venv/bin/pip install ase ovito vtk pyarrow polars

Checks (see docs/particle-files.md):
  ASE      ase.io.read(xyz, index=':') for every .xyz (trajectory.xyz too): positions, cell,
           pbc, get_velocities() == velo, radius/type/extra-column shapes and Origin;
           ase.io.read(dump, format='lammps-dump-text', units='si') positions and velocities.
  OVITO    import_file on .xyz and .dump: Radius, Velocity (3), extra vectors (3 components in
           XYZ), scalars (1), cell, Time; the species index as Particle Type (XYZ and dump);
           trajectory.xyz frame count; the wildcard frame.*.dump against the files on disk;
           Voronoi analysis of a 2D (bed/damper) frame: cell volumes add up to the cell.
  VTK      vtkPolyDataReader on .vtk with default settings and with ReadAllScalars/Vectors:
           point count, radius, velocity (3), every extra column, field TIME.
  Parquet  pyarrow schema: unit suffixes and field metadata 'unit'; polars means equal to
           the XYZ file's.
LIMIT lines are documented limitations of a reader (ASE ignores Origin; OVITO joins only its
own vector names in dumps), not counted as failures.
Exit status: 0 when nothing failed, 1 otherwise.
"""

import glob
import importlib.util
import os
import re
import sys

try:
    import numpy as np
except ImportError:  # every reader below needs numpy (they all install it)
    print("SKIP ASE, OVITO, VTK, Parquet: python module 'numpy' not installed")
    sys.exit(0)

# LIMIT: a documented limitation of the reader (docs/particle-files.md, "Readers tried"), not
# a fault of the file; printed so it stays visible, not counted as a failure.
RESULTS = {"PASS": 0, "FAIL": 0, "SKIP": 0, "LIMIT": 0}


def report(status, what, detail=""):
    RESULTS[status] += 1
    print(f"{status} {what}" + (f": {detail}" if detail else ""))


def check(what, ok, detail=""):
    report("PASS" if ok else "FAIL", what, detail)
    return ok


def have(module):
    return importlib.util.find_spec(module) is not None


def parse_xyz_header(path):
    """Comment-line keys of the first frame, the column layout and the rows as numbers."""
    with open(path) as f:
        n = int(f.readline())
        comment = f.readline()
        rows = [f.readline().split() for _ in range(n)]
    keys = dict(re.findall(r'(\w+)=("[^"]*"|\S+)', comment))
    keys = {k: v.strip('"') for k, v in keys.items()}
    props = keys["Properties"].split(":")
    columns, at = {}, 0
    for name, kind, width in zip(props[0::3], props[1::3], props[2::3]):
        columns[name] = (at, int(width), kind)
        at += int(width)
    return n, keys, columns, rows


def col(rows, columns, name):
    at, width, _ = columns[name]
    a = np.array([[float(x) for x in r[at:at + width]] for r in rows])
    return a if width > 1 else a[:, 0]


def extra_columns(columns):
    fixed = {"species", "type", "pos", "radius", "velo", "masses", "momenta"}
    return {k: v[1] for k, v in columns.items() if k not in fixed}


def check_ase(snap, xyz_files, dumps):
    import ase
    import ase.io
    from ase import units

    for path in xyz_files:
        name = os.path.relpath(path, os.path.dirname(snap))
        try:
            frames = ase.io.read(path, index=":")
        except Exception as e:  # noqa: BLE001
            check(f"ASE {ase.__version__} read {name}", False, repr(e))
            continue
        n, keys, columns, rows = parse_xyz_header(path)
        with open(path) as f:
            count = sum(1 for line in f if re.fullmatch(r"\d+\s*", line))
        a = frames[0]
        lattice = np.array([float(x) for x in keys["Lattice"].split()]).reshape(3, 3)
        pbc = [p == "T" for p in keys["pbc"].split()]
        ok = (
            len(frames) == count
            and len(a) == n
            and np.array_equal(a.positions, col(rows, columns, "pos"))
            and np.array_equal(a.cell[:], lattice)
            and list(a.pbc) == pbc
            and set(a.get_chemical_symbols()) == {"X"}
            and np.allclose(a.get_velocities(), a.arrays["velo"], rtol=1e-9, atol=0)
            and np.array_equal(a.arrays["radius"], col(rows, columns, "radius"))
            and np.array_equal(a.arrays["type"], col(rows, columns, "type").astype(int))
            and all(a.arrays[k].shape == ((n,) if w == 1 else (n, w))
                    for k, w in extra_columns(columns).items())
        )
        check(f"ASE {ase.__version__} read {name}", ok,
              f"{len(frames)} frame(s), {n} particles, cell, pbc, velocities, "
              f"arrays {sorted(extra_columns(columns))}")
        if np.any(np.array([float(x) for x in keys["Origin"].split()]) != 0):
            origin_kept = np.allclose(a.get_celldisp().ravel(), [float(x) for x in keys["Origin"].split()])
            report("PASS" if origin_kept else "LIMIT",
                   f"ASE {ase.__version__} cell origin of {name}",
                   "kept as celldisp" if origin_kept else
                   f"Origin={keys['Origin']} only in atoms.info['Origin'], celldisp "
                   f"{a.get_celldisp().ravel().tolist()} (ASE's extxyz reader ignores Origin)")
    for path in dumps:
        name = os.path.relpath(path, os.path.dirname(snap))
        xyz = path[:-len(".dump")] + ".xyz"
        try:
            d = ase.io.read(path, format="lammps-dump-text", units="si")
        except Exception as e:  # noqa: BLE001
            check(f"ASE {ase.__version__} lammps-dump-text {name}", False, repr(e))
            continue
        if not os.path.exists(xyz):
            continue
        x = ase.io.read(xyz)
        ok = (
            len(d) == len(x)
            and np.allclose(d.positions / units.m, x.positions, rtol=1e-12, atol=0)
            and np.allclose(d.get_velocities() / (units.m / units.s), x.arrays["velo"],
                            rtol=1e-9, atol=0)
            and np.allclose(d.cell[:] / units.m, x.cell[:], rtol=1e-12, atol=0)
        )
        check(f"ASE {ase.__version__} lammps-dump-text units='si' {name}", ok,
              f"{len(d)} particles; positions, velocities and cell equal the XYZ file's "
              f"(ASE keeps no radius or custom columns from a dump)")


def check_ovito(snap, xyz_files, dumps, is_2d):
    import ovito
    from ovito.io import import_file

    v = ovito.version_string
    for path in xyz_files + dumps:
        name = os.path.relpath(path, os.path.dirname(snap))
        try:
            pipeline = import_file(path)
            data = pipeline.compute()
        except Exception as e:  # noqa: BLE001
            check(f"OVITO {v} import {name}", False, repr(e))
            continue
        p = data.particles
        problems = []
        for prop, shape in (("Position", 3), ("Radius", 1), ("Velocity", 3)):
            if prop not in p:
                problems.append(f"no {prop}")
            elif (p[prop].shape[1] if p[prop].ndim > 1 else 1) != shape:
                problems.append(f"{prop} shape {p[prop].shape}")
        if "Radius" in p and not np.all(p["Radius"][...] > 0):
            problems.append("Radius not > 0")
        if data.cell is None or data.cell.volume <= 0:
            problems.append("no cell")
        if "Time" not in data.attributes:
            problems.append("no Time attribute")
        if path.endswith(".xyz"):
            n, _, columns, rows = parse_xyz_header(path)
            for k, w in extra_columns(columns).items():
                if k not in p:
                    problems.append(f"no {k}")
                elif (p[k].shape[1] if p[k].ndim > 1 else 1) != w:
                    problems.append(f"{k} shape {p[k].shape}, want {w} components")
            kinds = col(rows, columns, "type").astype(int)
        else:
            with open(path) as f:
                lines = f.read().splitlines()
            at = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
            names = lines[at].split()[2:]
            kinds = np.array([int(r.split()[names.index("type")]) for r in lines[at + 1:] if r])
            vectors = sorted({c[:-2] for c in names if c.endswith("_x")} - {""})
            if vectors:
                report("LIMIT", f"OVITO {v} vectors of {name}",
                       f"{vectors} arrive as separate scalar columns <name>_x/_y/_z, not as "
                       f"3-component properties (the XYZ file has them as vectors)")
        types = np.asarray(p.particle_types[...]) if "Particle Type" in p else None
        if types is None or len(np.unique(types)) != len(np.unique(kinds)):
            problems.append(
                f"Particle Type has {0 if types is None else len(np.unique(types))} kind(s), "
                f"the file's type column {len(np.unique(kinds))}")
        check(f"OVITO {v} import {name}", not problems,
              "; ".join(problems) or f"{p.count} particles, Radius, Velocity, cell, Time, "
              f"columns as properties, Particle Type = type")
        if os.path.basename(path) == "trajectory.xyz":
            with open(path) as f:
                count = sum(1 for line in f if re.fullmatch(r"\d+\s*", line))
            check(f"OVITO {v} frames of {name}", pipeline.source.num_frames == count,
                  f"num_frames {pipeline.source.num_frames}, file {count}")
    for ext in ("dump", "xyz"):
        files = glob.glob(os.path.join(snap, f"frame.*.{ext}"))
        if files:
            pipeline = import_file(os.path.join(snap, f"frame.*.{ext}"))
            check(f"OVITO {v} wildcard frame.*.{ext}", pipeline.source.num_frames == len(files),
                  f"num_frames {pipeline.source.num_frames}, files {len(files)}")
    if is_2d and dumps:
        from ovito.modifiers import VoronoiAnalysisModifier

        path = dumps[0]
        pipeline = import_file(path)
        pipeline.modifiers.append(VoronoiAnalysisModifier(use_radii=True))
        try:
            data = pipeline.compute()
            total = data.particles["Atomic Volume"][...].sum()
            check(f"OVITO {v} Voronoi analysis of {os.path.basename(path)}",
                  np.isclose(total, data.cell.volume, rtol=1e-9),
                  f"cell volumes sum {total:.6g} m3 = cell {data.cell.volume:.6g} m3")
        except Exception as e:  # noqa: BLE001
            check(f"OVITO {v} Voronoi analysis of {os.path.basename(path)}", False, repr(e))


def check_vtk(snap, vtks):
    import vtk

    v = vtk.vtkVersion.GetVTKVersion()
    for path in vtks:
        name = os.path.relpath(path, os.path.dirname(snap))
        xyz = path[:-len(".vtk")] + ".xyz"
        extra = extra_columns(parse_xyz_header(xyz)[2]) if os.path.exists(xyz) else {}
        want = {"id": 1, "type": 1, "radius": 1, "velocity": 3, "mass": 1, **extra}
        for read_all in (False, True):
            r = vtk.vtkPolyDataReader()
            r.SetFileName(path)
            if read_all:
                r.ReadAllScalarsOn()
                r.ReadAllVectorsOn()
            r.Update()
            o = r.GetOutput()
            pd = o.GetPointData()
            got = {pd.GetArrayName(i): pd.GetArray(i).GetNumberOfComponents()
                   for i in range(pd.GetNumberOfArrays())}
            t = o.GetFieldData().GetArray("TIME")
            missing = sorted(k for k in want if got.get(k) != want[k])
            how = "ReadAllScalars/VectorsOn" if read_all else "default settings"
            check(f"VTK {v} vtkPolyDataReader ({how}) {name}",
                  r.GetErrorCode() == 0 and o.GetNumberOfPoints() > 0 and t is not None
                  and not missing,
                  f"{o.GetNumberOfPoints()} points, TIME {t.GetValue(0) if t else None}, "
                  + (f"arrays read {sorted(got)}, missing {missing}" if missing
                     else f"arrays {sorted(got)}"))


def check_parquet(snap, parquets):
    import pyarrow
    import pyarrow.parquet as pq

    polars = None
    if have("polars"):
        import polars
    else:
        report("SKIP", "polars", "not installed")
    for path in parquets:
        name = os.path.relpath(path, os.path.dirname(snap))
        schema = pq.read_schema(path)
        problems = []
        for field in schema:
            unit = (field.metadata or {}).get(b"unit")
            if field.name in ("id", "species", "type"):
                continue
            if unit is None:
                problems.append(f"{field.name} has no unit metadata")
        for want in ("time_s", "x_m", "y_m", "z_m", "radius_m", "vx_m_per_s", "mass_kg"):
            if want not in schema.names:
                problems.append(f"no {want}")
        units = {f.name: f.metadata[b"unit"].decode() for f in schema if f.metadata}
        check(f"pyarrow {pyarrow.__version__} schema {name}", not problems,
              "; ".join(problems) or ", ".join(f"{k} [{u}]" for k, u in units.items()))
        xyz = path[:-len(".parquet")] + ".xyz"
        if polars is not None and os.path.exists(xyz):
            df = polars.read_parquet(path)
            _, _, columns, rows = parse_xyz_header(xyz)
            pos, radius = col(rows, columns, "pos"), col(rows, columns, "radius")
            means = df.select(polars.col("x_m", "y_m", "z_m", "radius_m").mean()).row(0)
            check(f"polars {polars.__version__} means {name}",
                  np.allclose(means, [*pos.mean(axis=0), radius.mean()], rtol=1e-12, atol=0),
                  f"{df.height} rows; mean x, y, z, radius = "
                  + ", ".join(f"{m:.6g}" for m in means) + " m, as in the XYZ file")


def main():
    dirs = sys.argv[1:]
    if not dirs:
        sys.exit(__doc__)
    tools = {"ASE": "ase", "OVITO": "ovito", "VTK": "vtk", "Parquet": "pyarrow"}
    for tool, module in tools.items():
        if not have(module):
            report("SKIP", tool, f"python module '{module}' not installed")
    for d in dirs:
        snap = os.path.join(d, "snapshots")
        print(f"== {snap}")
        files = lambda ext: sorted(glob.glob(os.path.join(snap, f"*.{ext}")))  # noqa: E731
        moments = lambda ext: [f for f in files(ext)  # noqa: E731
                               if not os.path.basename(f).startswith("frame.")]
        xyz_files, dumps = moments("xyz"), moments("dump")
        first = parse_xyz_header(xyz_files[0])[1] if xyz_files else {}
        lattice = [float(x) for x in first.get("Lattice", "1 0 0 0 1 0 0 0 1").split()]
        is_2d = "force_magnitude" in first.get("Properties", "") and lattice[8] < lattice[4]
        for tool, module in tools.items():
            if not have(module):
                continue
            try:
                if tool == "ASE":
                    check_ase(snap, xyz_files, dumps)
                elif tool == "OVITO":
                    check_ovito(snap, xyz_files, dumps, is_2d)
                elif tool == "VTK":
                    check_vtk(snap, moments("vtk"))
                else:
                    check_parquet(snap, moments("parquet"))
            except Exception as e:  # noqa: BLE001
                check(f"{tool} on {snap}", False, f"checker raised {e!r}")
    print(f"== {RESULTS['PASS']} PASS, {RESULTS['FAIL']} FAIL, {RESULTS['SKIP']} SKIP, "
          f"{RESULTS['LIMIT']} LIMIT (documented reader limitations)")
    sys.exit(1 if RESULTS["FAIL"] else 0)


if __name__ == "__main__":
    main()
