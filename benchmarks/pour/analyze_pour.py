#!/usr/bin/env python3
"""Summarise the pour benchmark runs written by run_pour.sh (standard library only).

Input: WORKDIR/runs.tsv, one line per run, tab-separated:
    code  variant  threads  mpi_ranks  wall_s  path
  code = sparkdem: path is the output directory (summary.json, timeseries.csv, results.h5)
  code = lammps:   path is the run directory (screen.out with thermo + "Loop time", lammps_final.dump)

Figures (defined once, the same for both codes):
  particle_steps_per_s  N x steps / wall time of the run loop
                        (sparkdem: stage "pour" wall_time_s of summary.json; LAMMPS: "Loop time")
  ke_at_<step>_J        kinetic energy, translational + rotational [J]
                        (sparkdem: timeseries column kinetic_energy; LAMMPS: thermo ke + c_erot)
  bed_height_m          95th percentile of z + r over all particles of the final state [m]
  mean_coordination     2 x (particle pairs with |x_i - x_j| < r_i + r_j) / N, final state
                        (particle-particle contacts only, walls not counted)
"""
import argparse
import csv
import json
import math
import os
import re
import sys


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


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--csv", required=True, help="results file (written to a temporary file, then renamed)")
    ap.add_argument("--dt", type=float, default=1e-5)
    ap.add_argument("--ke-every", type=int, default=5000, help="steps between the compared KE samples")
    args = ap.parse_args()

    runs = []
    with open(os.path.join(args.workdir, "runs.tsv")) as f:
        for line in f:
            if not line.strip() or line.startswith("#"):
                continue
            code, variant, threads, ranks, wall, path = line.rstrip("\n").split("\t")
            r = sparkdem_run(path, args.dt) if code == "sparkdem" else lammps_run(path)
            r.update(code=code, variant=variant, threads=int(threads), mpi_ranks=int(ranks), wall_s=float(wall))
            r["particle_steps_per_s"] = r["particles"] * r["steps"] / r["loop_s"] if r["loop_s"] > 0 else float("nan")
            r["bed_height_m"] = percentile([p[2] + q for p, q in zip(r["pos"], r["rad"])], 95.0)
            r["mean_coordination"] = coordination(r["pos"], r["rad"])
            runs.append(r)
    if not runs:
        sys.exit("no runs in runs.tsv")

    steps = max(r["steps"] for r in runs)
    ke_steps = list(range(args.ke_every, steps + 1, args.ke_every))
    header = ["code", "variant", "threads", "mpi_ranks", "particles", "steps", "wall_s", "loop_s",
              "particle_steps_per_s"] + [f"ke_at_{s}_J" for s in ke_steps] + ["bed_height_m", "mean_coordination"]
    tmp = args.csv + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in runs:
            w.writerow([r["code"], r["variant"], r["threads"], r["mpi_ranks"], r["particles"], r["steps"],
                        f"{r['wall_s']:.3f}", f"{r['loop_s']:.3f}", f"{r['particle_steps_per_s']:.6g}"] +
                       [f"{r['ke'].get(s, float('nan')):.8g}" for s in ke_steps] +
                       [f"{r['bed_height_m']:.6g}", f"{r['mean_coordination']:.5g}"])
    os.replace(tmp, args.csv)

    # ---- report ----
    print(f"\n== pour benchmark: {runs[0]['particles']} particles, {steps} steps (dt {args.dt:g} s) ==")
    print(f"{'code':9s} {'variant':12s} {'thr':>3s} {'mpi':>3s} {'wall_s':>9s} {'loop_s':>9s} {'part-steps/s':>13s}"
          f" {'bed_h [mm]':>10s} {'coord':>6s}")
    for r in runs:
        print(f"{r['code']:9s} {r['variant']:12s} {r['threads']:3d} {r['mpi_ranks']:3d} {r['wall_s']:9.2f} "
              f"{r['loop_s']:9.2f} {r['particle_steps_per_s']:13.4g} {1e3 * r['bed_height_m']:10.3f} "
              f"{r['mean_coordination']:6.3f}")
    ref = next((r for r in runs if r["code"] == "lammps" and r["variant"] == "serial"), None)
    spk = {r["threads"]: r for r in runs if r["code"] == "sparkdem"}
    if 1 in spk:
        for t, r in sorted(spk.items()):
            if t != 1:
                print(f"sparkdem speed-up {t} threads / 1 thread: {r['particle_steps_per_s'] / spk[1]['particle_steps_per_s']:.3f}"
                      f" (ideal {t})")
        base = spk[1]
        for t, r in sorted(spk.items()):
            if t == 1:
                continue
            same = all(r["ke"].get(s) == base["ke"].get(s) for s in base["ke"])
            print(f"sparkdem {t} threads vs 1 thread: kinetic-energy series "
                  f"{'bit-identical' if same else 'differs'}; bed height {pct(r['bed_height_m'], base['bed_height_m']):+.3f} %, "
                  f"coordination {pct(r['mean_coordination'], base['mean_coordination']):+.3f} %")
    if ref is None:
        print("no LAMMPS reference run: speed ratio and physics comparison skipped")
        return
    for r in runs:
        if r is ref:
            continue
        print(f"speed ratio {r['code']}/{r['variant']}/{r['threads']}thr/{r['mpi_ranks']}mpi vs LAMMPS serial: "
              f"{r['particle_steps_per_s'] / ref['particle_steps_per_s']:.3f}")
    # Physics: sparkdem (fewest threads; the other thread counts are compared with it above) against
    # every LAMMPS run, on every KE sample of the run (every 500 steps) and on the final state.
    spk_ref = spk[min(spk)] if spk else None
    for lr in (r for r in runs if r["code"] == "lammps") if spk_ref else ():
        print(f"\nphysics, sparkdem {spk_ref['threads']} thread(s) against LAMMPS {lr['variant']} "
              f"(difference in percent of LAMMPS):")
        for s in ke_steps:
            a, b = spk_ref["ke"].get(s), lr["ke"].get(s)
            if a is not None and b is not None:
                print(f"  KE at step {s:6d} (t = {s * args.dt:.3f} s): sparkdem {a:.6g} J, LAMMPS {b:.6g} J, "
                      f"{pct(a, b):+.3f} %")
        common = [s for s in lr["ke"] if s in spk_ref["ke"] and lr["ke"][s] > 0]
        if common:
            worst = max(common, key=lambda s: abs(pct(spk_ref["ke"][s], lr["ke"][s])))
            print(f"  largest KE difference over all {len(common)} samples: {pct(spk_ref['ke'][worst], lr['ke'][worst]):+.3g} % "
                  f"at step {worst} (KE {lr['ke'][worst]:.3g} J)")
        print(f"  bed height (p95 of z+r): sparkdem {1e3 * spk_ref['bed_height_m']:.3f} mm, LAMMPS "
              f"{1e3 * lr['bed_height_m']:.3f} mm, {pct(spk_ref['bed_height_m'], lr['bed_height_m']):+.3f} %")
        print(f"  mean coordination: sparkdem {spk_ref['mean_coordination']:.4f}, LAMMPS {lr['mean_coordination']:.4f}, "
              f"{pct(spk_ref['mean_coordination'], lr['mean_coordination']):+.3f} %")
    print(f"\nwrote {args.csv}")


if __name__ == "__main__":
    main()
