"""SIMD lane paths against the scalar path and the serial LAMMPS peer, one thread (issue 63 item 1).

    /usr/bin/python3 -m benchmarks.lanes.ab --sparkdem BUILD/sparkdem --workdir DIR [--repeats 3] [--cpu 0]

For each scene (the dense bed and the pour at their benchmark lengths, 10,000 and 30,000 steps, with
their benchmark LAMMPS inputs; --steps shortens both), every round runs LAMMPS and sparkdem under SPARKDEM_LANES=scalar, avx2 and avx512
(a path the processor lacks falls back to the widest it has), one after the other (interleaved, so the machine's drift hits every
variant alike), pinned to one CPU with one OpenMP thread; the wall time of the whole process is
timed. Each sparkdem run's final state must equal the scalar run's in every dataset (the lane paths
give the same bits; a difference stops the benchmark). Writes benchmarks/lanes/results.csv: per
scene and variant the median, min and max wall time, the speed-up over the scalar path and the
ratio LAMMPS time / sparkdem time, with the CPU model and the load averages before and after.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import time

import h5py
import numpy as np

from benchmarks.perf import harness

SCENES = {
    "dense_bed": ("benchmarks/mechanics/dense_bed.json", "benchmarks/mechanics/lammps_dense_bed.in"),
    "pour": ("configs/pour.json", "benchmarks/pour/lammps_pour_dump.in"),
}
OUT = os.path.join(harness.REPO, "benchmarks", "lanes", "results.csv")


def scenes(workdir, steps=None):
    """Each scene's sparkdem JSON (no frames; its last stage at `steps` steps when given) and LAMMPS
    input (`run` of the same steps, no dump); returns {name: (json, input, steps)}."""
    out = {}
    for name, (config, lammps) in SCENES.items():
        c = harness.load_config(config)
        steps_of = steps or c["stages"][-1]["stop"]["steps"]
        c["stages"][-1]["stop"] = {"steps": steps_of}
        c["stages"][-1]["output"] = {"frame_every": 0, "timeseries_every": 500, "checkpoint_every": 0}
        path = os.path.join(workdir, name + ".json")
        with open(path, "w") as f:
            json.dump(c, f)
        with open(os.path.join(harness.REPO, lammps)) as f:
            text = f.read()
        text = re.sub(r"^run\s+\d+", f"run             {steps_of}", text, flags=re.M)
        text = "\n".join(l for l in text.splitlines() if not l.startswith("write_dump"))
        lpath = os.path.join(workdir, name + ".in")
        with open(lpath, "w") as f:
            f.write(text + "\n")
        out[name] = (path, lpath, steps_of)
    return out


def timed(cmd, env, cpu):
    t0 = time.monotonic()
    subprocess.run(["taskset", "-c", str(cpu)] + cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.monotonic() - t0


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def same_state(a, b, ignore=()):
    """Every dataset of two HDF5 files equal (NaN equal to NaN), those named in `ignore` aside."""
    da, db = datasets(a), datasets(b)
    keys = da.keys() - set(ignore)
    return keys == db.keys() - set(ignore) and all(np.array_equal(da[k], db[k], equal_nan=da[k].dtype.kind == "f") for k in keys)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--cpu", type=int, default=0)
    ap.add_argument("--lmp", default=shutil.which("lmp"))
    a = ap.parse_args(argv)
    os.makedirs(a.workdir, exist_ok=True)
    sparkdem = os.path.abspath(a.sparkdem)
    isa = subprocess.run([sparkdem, "--version"], capture_output=True, text=True).stdout
    variants = ["scalar", "avx2", "avx512"]
    load0 = os.getloadavg()
    rows = []
    for name, (scene, lammps, steps) in scenes(a.workdir, a.steps).items():
        base = dict(os.environ, OMP_NUM_THREADS="1")

        def run(v, rep):
            if v == "lammps":
                return timed([a.lmp, "-in", lammps, "-log", "none", "-screen", "none"], base, a.cpu)
            out = os.path.join(a.workdir, f"{name}_{v}")
            shutil.rmtree(out, ignore_errors=True)
            t = timed([sparkdem, "run", scene, "-o", out, "--quiet", "--threads", "1"], dict(base, SPARKDEM_LANES=v), a.cpu)
            if v != "scalar" and not same_state(os.path.join(a.workdir, f"{name}_scalar", "final_state.h5"), os.path.join(out, "final_state.h5")):
                raise SystemExit(f"{name}: the {v} path's final state differs from the scalar path's")
            return t

        got = harness.interleave((["lammps"] if a.lmp else []) + variants, a.repeats, run)
        scalar = harness.stats(got["scalar"])["median"]
        lmp = harness.stats(got["lammps"])["median"] if a.lmp else None
        for v, times in got.items():
            s = harness.stats(times)
            rows.append({"scene": name, "steps": steps, "variant": v, "wall_s_median": round(s["median"], 3),
                         "wall_s_min": round(s["min"], 3), "wall_s_max": round(s["max"], 3), "repeats": s["n"],
                         "speedup_vs_scalar": "" if v == "lammps" else round(scalar / s["median"], 3),
                         "lammps_over_sparkdem": "" if v == "lammps" or lmp is None else round(lmp / s["median"], 3)})
    load1 = os.getloadavg()
    m = harness.machine()
    for r in rows:
        r.update({"cpu_model": m["cpu_model"], "load_before": round(load0[0], 2), "load_after": round(load1[0], 2),
                  "sparkdem": isa.strip().splitlines()[0] if isa else ""})
    harness.write_csv_atomic(OUT, rows)
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
