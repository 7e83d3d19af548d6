"""Readers of a pour or dense-bed run of both codes, for the perf case `mechanics`
(benchmarks/perf/cases.py; standard library, and h5py for sparkdem's final frame).

  sparkdem_run(outdir, dt)  summary.json, timeseries.csv and the last frame of results.h5
  lammps_run(rundir)        screen.out (thermo + "Loop time") and lammps_final.dump

Figures (defined once, the same for both codes):
  loop_s                the wall time of the run loop (sparkdem: the last dynamics stage's
                        wall_time_s in summary.json; LAMMPS: "Loop time")
  ke                    kinetic energy per step, translational + rotational [J]
                        (sparkdem: timeseries column kinetic_energy; LAMMPS: thermo ke + c_erot)
  coordination()        2 x (particle pairs with |x_i - x_j| < r_i + r_j) / N, final state
                        (particle-particle contacts only, walls not counted)
  percentile()          e.g. the bed height, the 95th percentile of z + r
"""
import csv
import json
import math
import os
import re


def percentile(values, q):
    """Linear-interpolation percentile (the numpy default), q in [0, 100]."""
    v = sorted(values)
    if not v:
        return float("nan")
    pos = (len(v) - 1) * q / 100.0
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def coordination(pos, rad):
    """Mean coordination 2 P / N, P = pairs with distance < r_i + r_j (cell list, pure Python)."""
    n = len(pos)
    if n == 0:
        return float("nan")
    cell = 2.0 * max(rad)
    cells = {}
    for i, (x, y, z) in enumerate(pos):
        cells.setdefault((int(math.floor(x / cell)), int(math.floor(y / cell)), int(math.floor(z / cell))), []).append(i)
    offsets = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]
    pairs = 0
    for (cx, cy, cz), members in cells.items():
        for dx, dy, dz in offsets:
            other = cells.get((cx + dx, cy + dy, cz + dz))
            if other is None:
                continue
            for i in members:
                xi, yi, zi = pos[i]
                ri = rad[i]
                for j in other:
                    if j <= i:
                        continue
                    xj, yj, zj = pos[j]
                    s = ri + rad[j]
                    d2 = (xi - xj) ** 2 + (yi - yj) ** 2 + (zi - zj) ** 2
                    if d2 < s * s:
                        pairs += 1
    return 2.0 * pairs / n


def h5_numbers(h5file, dataset):
    """All numbers of one dataset, flattened, as floats (h5py)."""
    import h5py
    with h5py.File(h5file, "r") as f:
        return [float(x) for x in f[dataset][()].ravel()]


def sparkdem_final_state(outdir):
    import h5py
    h5 = os.path.join(outdir, "results.h5")
    with h5py.File(h5, "r") as f:
        frames = sorted(f["frames"].keys())
    last = "/frames/" + frames[-1] + "/particles/"
    xyz = h5_numbers(h5, last + "position")
    rad = h5_numbers(h5, last + "radius")
    pos = [tuple(xyz[3 * k:3 * k + 3]) for k in range(len(xyz) // 3)]
    if len(pos) != len(rad):
        raise RuntimeError(f"{h5}: {len(pos)} positions but {len(rad)} radii")
    return pos, rad


def sparkdem_run(outdir, dt):
    with open(os.path.join(outdir, "summary.json")) as f:
        summary = json.load(f)
    k_stage = max(k for k, s in enumerate(summary["stages"]) if s.get("type") == "dynamics")
    stage = summary["stages"][k_stage]
    ke = {}
    with open(os.path.join(outdir, "timeseries.csv")) as f:
        for row in csv.DictReader(f):
            if int(float(row["stage"])) == k_stage:
                ke[int(round(float(row["time"]) / dt))] = float(row["kinetic_energy"])
    pos, rad = sparkdem_final_state(outdir)
    return {"particles": stage["particles"], "steps": stage["steps"], "loop_s": stage["wall_time_s"], "ke": ke,
            "pos": pos, "rad": rad}


def lammps_run(rundir):
    ke = {}
    loop_s = steps = atoms = None
    header = None
    with open(os.path.join(rundir, "screen.out")) as f:
        for line in f:
            tok = line.split()
            if tok[:1] == ["Step"]:
                header = tok
                continue
            m = re.match(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", line)
            if m:
                loop_s, steps, atoms = float(m.group(1)), int(m.group(3)), int(m.group(4))
                header = None
                continue
            if header and len(tok) == len(header) and re.match(r"^\d+$", tok[0]):
                row = dict(zip(header, tok))
                ke[int(row["Step"])] = float(row["KinEng"]) + float(row["c_erot"])
    if loop_s is None:
        raise RuntimeError(f"{rundir}/screen.out: no 'Loop time' line (did LAMMPS fail?)")
    pos, rad = [], []
    with open(os.path.join(rundir, "lammps_final.dump")) as f:
        lines = f.read().splitlines()
    k = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[k].split()[2:]
    ix, iy, iz, ir = (cols.index(c) for c in ("x", "y", "z", "radius"))
    for l in lines[k + 1:]:
        t = l.split()
        if len(t) == len(cols):
            pos.append((float(t[ix]), float(t[iy]), float(t[iz])))
            rad.append(float(t[ir]))
    return {"particles": atoms, "steps": steps, "loop_s": loop_s, "ke": ke, "pos": pos, "rad": rad}


def pct(a, b):
    """Difference of a from the reference b in percent."""
    if b == 0 or a is None or b is None or not math.isfinite(a) or not math.isfinite(b):
        return float("nan")
    return 100.0 * (a - b) / abs(b)
