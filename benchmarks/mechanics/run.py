#!/usr/bin/python3
"""Mechanics speed against LAMMPS (issue 23 item 2): the peer pour and a contact-dominated bed.

Scenes (the same scene in both codes, the same law, skin 0.4 mm and rebuild rule, dt = 1e-5 s):
  pour       configs/pour.json against benchmarks/pour/lammps_pour_dump.in (the shared peer input
             plus output commands): 23,976 spheres falling into a box, at most ~1 contact per sphere
             at the end (run_pour.sh explains the mapping); 30,000 steps.
  dense_bed  benchmarks/mechanics/dense_bed.json against lammps_dense_bed.in: 27,000 spheres on a
             simple-cubic lattice squeezed by six walls, 5.8 pair contacts per sphere for the whole
             run; 10,000 steps.
Each repeat runs every variant once, interleaved (sparkdem 1 thread, LAMMPS serial, sparkdem 2
threads under the default OpenMP wait policy, sparkdem 2 threads under OMP_WAIT_POLICY=PASSIVE);
the table gives the median over the repeats of the run loop's wall time (sparkdem: the dynamics
stage's wall_time_s; LAMMPS: "Loop time"), the speed ratios, and the physics of the last repeat
(kinetic energy at every 500 steps, translational + rotational, and the final mean coordination,
computed by the same code for both; benchmarks/pour/analyze_pour.py).

    /usr/bin/python3 benchmarks/mechanics/run.py --sparkdem build/sparkdem [--repeats 5]
        [--scenes pour dense_bed] [--out benchmarks/mechanics/results.csv] [--workdir DIR]

Needs `lmp` (Debian package lammps) and h5dump (hdf5-tools). Run it on an idle machine: about
25 minutes for 5 repeats on the 2-core development machine.
"""
import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
from benchmarks.pour import analyze_pour  # (KE, final state and coordination readers shared with the pour benchmark)

SCENES = {
    "pour": {"config": os.path.join(REPO, "configs", "pour.json"),
             "lammps": os.path.join(REPO, "benchmarks", "pour", "lammps_pour_dump.in"), "steps": 30000},
    "dense_bed": {"config": os.path.join(HERE, "dense_bed.json"),
                  "lammps": os.path.join(HERE, "lammps_dense_bed.in"), "steps": 10000},
}
# (name, threads, OMP_WAIT_POLICY or None for the runtime default)
SPARKDEM_VARIANTS = [("sparkdem_t1", 1, None), ("sparkdem_t2", 2, None), ("sparkdem_t2_passive", 2, "passive")]


def sparkdem_scene(config, path):
    """The scene with the benchmark's output: time series every 500 steps, final frame, no checkpoint."""
    c = json.load(open(config))
    dyn = [s for s in c["stages"] if s.get("type", "dynamics") == "dynamics"][-1]
    dyn["output"] = {"frame_every": 0, "timeseries_every": 500, "checkpoint_every": 0}
    with open(path, "w") as f:
        json.dump(c, f, indent=1)


def run_sparkdem(exe, scene, out, threads, policy):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    env.pop("OMP_WAIT_POLICY", None)
    if policy:
        env["OMP_WAIT_POLICY"] = policy
    subprocess.run(["rm", "-rf", out], check=True)
    t0 = time.monotonic()
    subprocess.run([exe, "run", scene, "-o", out, "--threads", str(threads), "--quiet"], check=True, env=env,
                   stdout=subprocess.DEVNULL)
    return time.monotonic() - t0


def run_lammps(lammps_in, rundir):
    os.makedirs(rundir, exist_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    t0 = time.monotonic()
    with open(os.path.join(rundir, "screen.out"), "w") as screen:
        subprocess.run(["lmp", "-in", lammps_in, "-log", "none"], cwd=rundir, check=True, env=env, stdout=screen)
    return time.monotonic() - t0


def lammps_version():
    out = subprocess.run(["lmp", "-h"], capture_output=True, text=True).stdout.splitlines()
    version = next((l.split(" - ", 1)[1].strip() for l in out if l.startswith("Large-scale Atomic") and " - " in l),
                   "unknown")
    compiler = next((l.strip() for l in out if "Compiler:" in l), "")
    return f"{version} {compiler}".strip()


def ke_difference(a, b):
    """Largest relative KE difference of a from b [%] over the common steps with KE > 0."""
    worst = 0.0
    for step, kb in b.items():
        if step in a and kb > 0.0:
            worst = max(worst, abs(analyze_pour.pct(a[step], kb)))
    return worst


def ke_difference_over_peak(a, b):
    """Largest |KE_a - KE_b| over the common steps, relative to b's largest KE [%] (a ringing bed's
    KE passes near zero, where the per-sample relative difference says little)."""
    peak = max(b.values(), default=0.0)
    if peak <= 0.0:
        return float("nan")
    return 100.0 * max((abs(a[s] - kb) for s, kb in b.items() if s in a), default=0.0) / peak


def measure_scene(name, args, workdir):
    spec = SCENES[name]
    scene = os.path.join(workdir, f"{name}.json")
    sparkdem_scene(spec["config"], scene)
    loops = {v[0]: [] for v in SPARKDEM_VARIANTS}
    loops["lammps_serial"] = []
    walls = {k: [] for k in loops}
    runs = {}
    for rep in range(args.repeats):
        order = [SPARKDEM_VARIANTS[0], ("lammps_serial", 1, None)] + SPARKDEM_VARIANTS[1:]
        for variant, threads, policy in order:
            path = os.path.join(workdir, f"{name}_{variant}")
            if variant == "lammps_serial":
                wall = run_lammps(spec["lammps"], path)
                res = analyze_pour.lammps_run(path)
            else:
                wall = run_sparkdem(args.sparkdem, scene, path, threads, policy)
                res = analyze_pour.sparkdem_run(path, 1e-5)
            loops[variant].append(res["loop_s"])
            walls[variant].append(wall)
            runs[variant] = res
            print(f"{name} repeat {rep + 1}/{args.repeats} {variant}: loop {res['loop_s']:.2f} s, process {wall:.2f} s",
                  flush=True)
    ref = runs["lammps_serial"]
    lammps_med = statistics.median(loops["lammps_serial"])
    rows = []
    for variant in loops:
        res = runs[variant]
        med = statistics.median(loops[variant])
        rows.append({
            "scene": name, "variant": variant, "particles": res["particles"], "steps": res["steps"],
            "repeats": len(loops[variant]), "loop_s_median": f"{med:.3f}",
            "loop_s_min": f"{min(loops[variant]):.3f}", "loop_s_max": f"{max(loops[variant]):.3f}",
            "process_s_median": f"{statistics.median(walls[variant]):.3f}",
            "particle_steps_per_s": f"{res['particles'] * res['steps'] / med:.4g}",
            "speedup_vs_lammps_serial": f"{lammps_med / med:.3f}",
            "max_ke_difference_vs_lammps_pct": f"{ke_difference(res['ke'], ref['ke']):.3g}",
            "ke_difference_over_peak_pct": f"{ke_difference_over_peak(res['ke'], ref['ke']):.3g}",
            "mean_coordination": f"{analyze_pour.coordination(res['pos'], res['rad']):.4f}",
        })
    t1 = statistics.median(loops["sparkdem_t1"])
    for r in rows:
        if r["variant"].startswith("sparkdem_t2"):
            r["thread_speedup"] = f"{t1 / float(r['loop_s_median']):.3f}"
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--out", default=os.path.join(HERE, "results.csv"))
    ap.add_argument("--workdir", default=None)
    args = ap.parse_args()
    args.sparkdem = os.path.abspath(args.sparkdem)
    workdir = args.workdir or tempfile.mkdtemp(prefix="sparkdem_mechanics_")
    os.makedirs(workdir, exist_ok=True)
    load = os.getloadavg()[0]
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print(f"load average {load:.2f}; work directory {workdir}; LAMMPS: {lammps_version()}", flush=True)
    rows = []
    for name in args.scenes:
        rows += measure_scene(name, args, workdir)
    fields = ["scene", "variant", "particles", "steps", "repeats", "loop_s_median", "loop_s_min", "loop_s_max",
              "process_s_median", "particle_steps_per_s", "speedup_vs_lammps_serial", "thread_speedup",
              "max_ke_difference_vs_lammps_pct", "ke_difference_over_peak_pct", "mean_coordination", "commit", "lammps", "load_average_at_start"]
    for r in rows:
        r.update({"commit": commit, "lammps": lammps_version(), "load_average_at_start": f"{load:.2f}"})
        r.setdefault("thread_speedup", "")
    tmp = args.out + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, args.out)
    for r in rows:
        print(f"{r['scene']:10s} {r['variant']:20s} loop {r['loop_s_median']:>8s} s  x LAMMPS {r['speedup_vs_lammps_serial']:>6s}"
              f"  threads {r['thread_speedup']:>6s}  KE diff {r['max_ke_difference_vs_lammps_pct']:>8s} %"
              f"  coordination {r['mean_coordination']}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
