"""The sintering law's SIMD lane paths against its scalar path on the main scenario's hot press (issue 63 item 1).

    /usr/bin/python3 -m benchmarks.lanes.sintering --sparkdem BUILD/sparkdem --workdir DIR [--repeats 2] [--steps 3000] [--cpu 0]

From configs/sps_nial.json (17,876 NiAl particles): its packing and heat stages are run once (two
threads) to the state at the start of the hot press; then the hot press - the scenario's own stage
with its `until` and snapshots, cut to --steps steps, no frames - is restarted from that state
under SPARKDEM_LANES=scalar, avx2 and avx512 in turn (interleaved rounds, one OpenMP thread, pinned
to one CPU; a path the processor lacks falls back to the widest it has). The figure is the hot
press stage's wall time (summary.json). Every lane path's final state must equal the scalar path's
in every dataset but the run record (wall times, paths; a difference stops the benchmark). Writes benchmarks/lanes/sintering.csv: per
variant the median, min and max wall time, the particle-steps per second and the speed-up over the
scalar path, with the CPU model and the load averages before and after.
"""
import argparse
import json
import os
import shutil
import subprocess

from benchmarks.lanes.ab import same_state
from benchmarks.perf import harness

OUT = os.path.join(harness.REPO, "benchmarks", "lanes", "sintering.csv")
CONFIG = "configs/sps_nial.json"
HOT_PRESS = 2  # the stage index of the hot press in CONFIG


def scenes(workdir, steps):
    """The scenario up to the heat stage, and up to the hot press cut to `steps` steps (no frames)."""
    c = harness.load_config(CONFIG)
    heat = dict(c, stages=c["stages"][:HOT_PRESS])
    press = dict(c, stages=c["stages"][:HOT_PRESS + 1])
    stage = dict(press["stages"][HOT_PRESS])
    stage["stop"] = {"steps": steps}
    stage["output"] = {"frame_every": 0, "timeseries_every": stage.get("output", {}).get("timeseries_every", 100)}
    press["stages"][HOT_PRESS] = stage
    paths = []
    for name, scene in (("heat", heat), ("hot_press", press)):
        path = os.path.join(workdir, name + ".json")
        with open(path, "w") as f:
            json.dump(scene, f)
        paths.append(path)
    return paths


def stage_seconds(out):
    with open(os.path.join(out, "summary.json")) as f:
        return next(s["wall_time_s"] for s in json.load(f)["stages"] if s["name"] == "hot_press")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--cpu", type=int, default=0)
    a = ap.parse_args(argv)
    os.makedirs(a.workdir, exist_ok=True)
    sparkdem = os.path.abspath(a.sparkdem)
    version = subprocess.run([sparkdem, "--version"], capture_output=True, text=True).stdout.strip()
    heat, press = scenes(a.workdir, a.steps)
    start = os.path.join(a.workdir, "heat_out")
    shutil.rmtree(start, ignore_errors=True)
    subprocess.run([sparkdem, "run", heat, "-o", start, "--quiet", "--threads", "2"], env=dict(os.environ, OMP_NUM_THREADS="2"),
                   check=True)
    particles = json.load(open(os.path.join(start, "summary.json")))["particles"]
    load0 = os.getloadavg()

    def run(v, rep):
        out = os.path.join(a.workdir, f"hot_press_{v}")
        shutil.rmtree(out, ignore_errors=True)
        subprocess.run(["taskset", "-c", str(a.cpu), sparkdem, "run", press, "--restart", os.path.join(start, "final_state.h5"), "-o", out,
                        "--quiet", "--threads", "1"], env=dict(os.environ, OMP_NUM_THREADS="1", SPARKDEM_LANES=v), check=True)
        # the run record of a restarted run holds its wall times and paths, not results
        if v != "scalar" and not same_state(os.path.join(a.workdir, "hot_press_scalar", "final_state.h5"), os.path.join(out, "final_state.h5"),
                                            ignore=("pipeline/record",)):
            raise SystemExit(f"the {v} path's final state differs from the scalar path's")
        return stage_seconds(out)

    got = harness.interleave(["scalar", "avx2", "avx512"], a.repeats, run)
    load1 = os.getloadavg()
    scalar = harness.stats(got["scalar"])["median"]
    m = harness.machine()
    rows = []
    for v, times in got.items():
        s = harness.stats(times)
        rows.append({"scene": "sps_nial hot press", "steps": a.steps, "particles": particles, "variant": v,
                     "wall_s_median": round(s["median"], 3), "wall_s_min": round(s["min"], 3), "wall_s_max": round(s["max"], 3),
                     "repeats": s["n"], "particle_steps_per_s": round(particles * a.steps / s["median"]),
                     "speedup_vs_scalar": round(scalar / s["median"], 3), "cpu_model": m["cpu_model"],
                     "load_before": round(load0[0], 2), "load_after": round(load1[0], 2), "sparkdem": version.splitlines()[0]})
    harness.write_csv_atomic(OUT, rows)
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
