#!/usr/bin/env python3
"""Cost of the adaptive step (issue 62 item 6): each scene at its fixed step against the same scene
with "dt": {"adaptive": 1.0, "max": <its fixed dt>, "check_every": K}, which keeps the fixed step
(the state's stable step stays above it) and pays only the estimates; runs interleaved in one
session, the least wall time of the repetitions kept (summary.json wall_time_s of the stepping stage).

usage: python3 -m benchmarks.adaptive_dt.cost [--sparkdem BUILD/sparkdem] [--reps 3] [--threads 2]
           [--check-every 50 100] [--out benchmarks/adaptive_dt/cost.csv]
Writes cost.csv: scene, particles, steps, check_every, fixed_s, adaptive_s, overhead_percent (A/B, from
the least wall times: on this machine the scatter between runs is several per cent, larger than the
effect), and from the adaptive runs' own summary.json (dt_adaptive.check_wall_time_s, every check timed
in the run itself; median over the repetitions): share_percent (the checks' share of the stage's wall
time, the figure to read), ms_per_check and check_in_steps (one check in steps of that run).
"""
import statistics
import argparse
import csv
import json
import os
import subprocess
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCENES = [("pour", "configs/pour.json", "pour"), ("dense_bed", "benchmarks/mechanics/dense_bed.json", "squeeze")]


def variant(config, stage, check_every):
    """The scene with its stepping stage adaptive (None: as shipped), written beside the config."""
    with open(os.path.join(REPO, config)) as f:
        c = json.load(f)
    st = next(s for s in c["stages"] if s["name"] == stage)
    if check_every:
        st["dt"] = {"adaptive": 1.0, "max": st["dt"], "check_every": check_every}
    path = os.path.join(REPO, os.path.dirname(config), ".adaptive_cost_%s_%s.json" % (stage, check_every or "fixed"))
    with open(path, "w") as f:
        json.dump(c, f)
    return path


def run(sparkdem, scene, threads, work):
    out = tempfile.mkdtemp(dir=work)
    subprocess.run([sparkdem, "run", scene, "-o", out, "--quiet", "--threads", str(threads)], check=True)
    with open(os.path.join(out, "summary.json")) as f:
        st = json.load(f)["stages"][-1]
    return st


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--check-every", type=int, nargs="+", default=[50, 100])
    ap.add_argument("--out", default=os.path.join(HERE, "cost.csv"))
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="sparkdem_adaptive_cost_")
    rows = []
    for name, config, stage in SCENES:
        files = {k: variant(config, stage, k) for k in [None] + a.check_every}
        try:
            best = {k: float("inf") for k in files}
            share = {k: [] for k in files}
            for _ in range(a.reps):  # interleaved: fixed, then each adaptive variant, every repetition
                for k, f in files.items():
                    st = run(a.sparkdem, f, a.threads, work)
                    steps, particles = st["steps"], st["particles"]
                    best[k] = min(best[k], st["wall_time_s"])
                    if k:
                        d = st["dt_adaptive"]
                        share[k].append((d["check_wall_time_s"], d["checks"], st["wall_time_s"]))
        finally:
            for f in files.values():
                os.remove(f)
        for k in a.check_every:
            extra = best[k] - best[None]
            check_s = statistics.median(c for c, n, w in share[k])
            checks = share[k][0][1]
            wall = statistics.median(w for c, n, w in share[k])
            rows.append({"scene": name, "particles": particles, "steps": steps, "check_every": k, "fixed_s": round(best[None], 3),
                         "adaptive_s": round(best[k], 3), "overhead_percent": round(100 * extra / best[None], 2),
                         "checks": checks, "share_percent": round(100 * check_s / wall, 2),
                         "ms_per_check": round(1e3 * check_s / checks, 3), "check_in_steps": round(check_s / checks / (wall / steps), 2)})
            print(rows[-1])
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
