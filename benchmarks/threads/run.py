#!/usr/bin/python3
"""Threads only where they pay (issue 23 item 1): wall time per step of small to large scenes on 1 and
2 threads, under the default OpenMP wait policy and OMP_WAIT_POLICY=PASSIVE.

Two scene families, made here (no config file): a simple-cubic lattice of n_x x n_y x n_z spheres
(d = 2 mm, glass-like, hertz_mindlin, E = 1e7 Pa), gravity;
  contacts: lattice constant 0.99 d inside a box of six walls (every interior sphere holds six
            contacts for the whole run), dt = 1e-5 s;
  bonds:    lattice constant d, every touching pair joined by a cohesive beam (cast-iron beam
            parameters of configs/materials/cast_iron_beams.json), no walls, dt = half the stable step.
Sizes 2 to 1e5 particles; steps chosen so that a run takes about a second. Variants: 1 thread, 2
threads, and 2 threads with every loop forced parallel (SPARKDEM_PARALLEL_MIN_ITEMS=1: the engine
before the minimum item counts of engine/core/parallel.hpp). Each (family, size, variant, policy)
is run --repeats times, interleaved, and the median of the dynamics stage's wall time
(summary.json) per step is reported, with the ratios to 1 thread.

    benchmarks/threads/run.py --sparkdem build/sparkdem [--out benchmarks/threads/results.csv] [--repeats 3]
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SHAPES = {2: (2, 1, 1), 10: (10, 1, 1), 100: (10, 10, 1), 300: (10, 10, 3), 1000: (10, 10, 10), 3000: (15, 20, 10),
          10000: (25, 20, 20), 100000: (50, 50, 40)}
VARIANTS = [(1, ""), (2, ""), (2, "1")]  # (threads, SPARKDEM_PARALLEL_MIN_ITEMS): "1" = every loop parallel (as before)
D = 2e-3


def scene(family, shape, steps):
    a = 0.99 * D if family == "contacts" else D
    n = shape
    c = {"name": f"threads_{family}", "seed": 1, "materials": [{"name": "glass", "density": 2500}],
         "contact": {"law": "hertz_mindlin",
                     "params": {"youngs_modulus": 1e7, "poisson_ratio": 0.3, "restitution": 0.3, "friction": 0.3}},
         "stages": [{"name": "create", "type": "lattice",
                     "generator": {"lo": [a, a, a], "hi": [n[0] * a, n[1] * a, n[2] * a], "spacing": a, "diameter": D}},
                    {"name": "run", "type": "dynamics", "dt": 1e-5,
                     "modules": {"gravity": {"acceleration": [0, 0, -9.81]}}, "stop": {"steps": steps},
                     "output": {"timeseries_every": steps}}]}
    if family == "contacts":
        lo, hi = 0.5 * a, [(k + 0.5) * a for k in n]
        c["walls"] = [{"name": f"{s}{ax}", "type": "plane",
                       "point": [lo if (s == "lo" and q == i) else (hi[q] if (s == "hi" and q == i) else 0.0) for q in range(3)],
                       "normal": [(1.0 if s == "lo" else -1.0) if q == i else 0.0 for q in range(3)]}
                      for i, ax in enumerate("xyz") for s in ("lo", "hi")]
    else:
        c["bonds"] = {"law": "cohesive_beam",
                      "params": {"$include": os.path.join(REPO, "configs", "materials", "cast_iron_beams.json")}}
        c["stages"][1]["create_bonds"] = {"gap_tolerance_relative": 0.02}
        del c["stages"][1]["dt"]
        c["stages"][1]["dt_fraction"] = 0.5  # the beams' stable step (about 1e-7 s)
    return c


def run_once(sparkdem, sc, threads, policy, forced, tmp):
    path = os.path.join(tmp, "scene.json")
    with open(path, "w") as f:
        json.dump(sc, f)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    env.pop("OMP_WAIT_POLICY", None)
    env.pop("SPARKDEM_PARALLEL_MIN_ITEMS", None)
    if forced:
        env["SPARKDEM_PARALLEL_MIN_ITEMS"] = forced
    if policy != "default":
        env["OMP_WAIT_POLICY"] = policy
    out = os.path.join(tmp, "out")
    subprocess.run([sparkdem, "run", path, "-o", out, "--threads", str(threads), "--quiet"], env=env, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    st = next(x for x in s["stages"] if x["name"] == "run")
    return st["wall_time_s"] / st["steps"], s["particles"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--out", default=os.path.join(HERE, "results.csv"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", type=int, nargs="+", default=sorted(SHAPES))
    ap.add_argument("--families", nargs="+", default=["contacts", "bonds"])
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for family in a.families:
            for n in a.sizes:
                steps = max(200, min(20000, int(2e7 / n)))
                sc = scene(family, SHAPES[n], steps)
                times = {}
                for _ in range(a.repeats):  # interleaved: every variant once per round
                    for policy in ("default", "PASSIVE"):
                        for threads, forced in VARIANTS:
                            t, count = run_once(a.sparkdem, sc, threads, policy, forced, tmp)
                            times.setdefault((policy, threads, forced), []).append(t)
                for policy in ("default", "PASSIVE"):
                    t1, t2, tf = (statistics.median(times[(policy,) + v]) for v in VARIANTS)
                    rows.append({"family": family, "particles": count, "steps": steps, "wait_policy": policy,
                                 "s_per_step_1_thread": f"{t1:.4g}", "s_per_step_2_threads": f"{t2:.4g}",
                                 "time_2_over_1": f"{t2 / t1:.3f}", "s_per_step_2_threads_all_parallel": f"{tf:.4g}",
                                 "time_2_all_parallel_over_1": f"{tf / t1:.3f}", "repeats": a.repeats})
                    print(rows[-1], flush=True)
    with open(a.out + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(a.out + ".tmp", a.out)


if __name__ == "__main__":
    main()
