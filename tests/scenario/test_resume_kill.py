#!/usr/bin/env python3
"""A killed run continues in place with nothing lost (issue 64): `sparkdem run --resume`.

A small SPS pipeline (configs/sps_nial_small.json cut down: pack, heat, hot press with snapshots,
the grain-boundary calibration sweep over the snapshots, a conductivity sweep; fewer particles
and shorter stops; wall-clock checkpoints every 0.1 s) is run once uninterrupted (A). The same
scene is then run into B and killed with SIGKILL at moments drawn from a seeded generator (each a
wall delay once the folder holds a restart point), each attempt after the first continuing with
`--resume`, then resumed to its end (a second --resume must say the run has completed and exit 0;
--resume into a missing folder and --resume with --restart must exit 2). B must equal A file by
file:

  * the same files (except run.log, which appends, checkpoint.h5 / checkpoint.previous.h5 and the
    watchdog's .healthy_state.h5, which depend on wall-clock timing);
  * every HDF5 file: the same datasets and attributes, byte for byte (NaN = NaN); the pipeline
    record (a JSON string, /pipeline/record) compared as JSON less its timings;
  * every CSV: the same columns and values, timing columns left out;
  * every JSON (summary.json less timings, resolved.json) and every other text file (results.xdmf)
    equal;
  * tools.plot_sps on B succeeds and writes the same data files (its CSVs, timing columns out) as
    on A.

Timings are the keys and columns named *wall_time*, *solve_time*, *_per_s or *seconds* (wall
and CPU time), and the counters of work done by one process (see docs/running.md, "If a run is
killed": neighbor_rebuilds, module_calls, core_wall_time_sampled_steps, dt_adaptive checks).

    /usr/bin/python3 tests/scenario/test_resume_kill.py --sparkdem BIN [--seed N] [--kills K] [--keep DIR]
Exit codes: 0 passed, 1 failed.
"""
import argparse
import csv
import json
import math
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# Files that depend on wall-clock timing or append (not compared).
NOT_COMPARED = {"run.log", "checkpoint.h5", "checkpoint.previous.h5", ".healthy_state.h5", "stdout.txt", "stderr.txt"}
# Keys of work counted by the process that did it (a resumed stage counts only its own part).
PROCESS_COUNTERS = {"neighbor_rebuilds", "module_calls", "core_wall_time_sampled_steps", "checks"}


def is_timing(name):
    n = name.lower()
    return "wall_time" in n or "solve_time" in n or n.endswith("_per_s") or "seconds" in n or n in PROCESS_COUNTERS


def scene():
    """configs/sps_nial_small.json cut down to a few seconds on one thread."""
    with open(os.path.join(REPO, "configs", "sps_nial_small.json")) as f:
        s = json.load(f)
    names = [st["name"] for st in s["stages"]]
    assert names == ["pack", "heat", "hot_press", "conductivity_gb", "conductivity_no_gb", "cooled_conductivity"], names
    s["stages"] = s["stages"][:5]  # without the cooled conductivity sweep (the longest stage)
    gen = s["stages"][0]["generator"]
    gen["length"] = gen["length"] * 0.5  # about half the particles
    s["stages"][1]["stop"] = {"time": 0.0006}
    press = s["stages"][2]
    press["time_scale"] = press["time_scale"] * 4  # the heating cycle in a quarter of the steps
    press["snapshots"]["at"] = [0.3, 0.25]
    press["until"] = {"porosity_mass": {"below": 0.245}}
    s["stages"][3]["sweep"]["calibrate"]["snapshot"] = 1
    for st in s["stages"]:
        st.setdefault("output", {})["checkpoint_every_s"] = 0.1
        if "sweep" not in st:
            st["output"]["frame_every"] = st["output"].get("timeseries_every", 200) * 10
    return s


def run(cmd, log):
    with open(log + ".out", "w") as out, open(log + ".err", "w") as err:
        return subprocess.run(cmd, stdout=out, stderr=err, env=env()).returncode


def env():
    e = dict(os.environ)
    e.update(OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
    return e


def attempt(cmd, delay, log, folder):
    """Starts `cmd`, kills it with SIGKILL `delay` s after `folder` holds a restart point (at once
    for a resumed attempt; a fresh one first writes its first, so that every kill leaves something
    to resume, however slow the machine); the exit code, or None when killed."""
    with open(log + ".out", "w") as out, open(log + ".err", "w") as err:
        p = subprocess.Popen(cmd, stdout=out, stderr=err, env=env())
        points = [os.path.join(folder, f) for f in ("final_state.h5", "checkpoint.h5")]
        while p.poll() is None and not any(os.path.exists(f) for f in points):
            time.sleep(0.005)
        try:
            return p.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGKILL)
            p.wait()
            return None


def files_of(d):
    out = set()
    for root, _, files in os.walk(d):
        for f in files:
            if f in NOT_COMPARED or f.endswith(".tmp"):
                continue
            out.add(os.path.relpath(os.path.join(root, f), d))
    return out


ROOTS = []  # the output directories compared: a path inside one reads as inside "OUT"


def strip_timings(j):
    """`j` without its timings, the output directory in its paths named OUT."""
    if isinstance(j, dict):
        return {k: strip_timings(v) for k, v in j.items() if not is_timing(k)}
    if isinstance(j, list):
        return [strip_timings(v) for v in j]
    if isinstance(j, str):
        for r in ROOTS:
            j = j.replace(r, "OUT")
    return j


def json_diff(a, b, where=""):
    """The first differences between two JSON values (NaN-free: JSON has none)."""
    if type(a) is not type(b):
        return [f"{where}: {a!r} != {b!r}"]
    if isinstance(a, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{where}/{k}: only in {'A' if k in a else 'B'}")
            else:
                out += json_diff(a[k], b[k], f"{where}/{k}")
        return out[:10]
    if isinstance(a, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items != {len(b)}"]
        out = []
        for k, (x, y) in enumerate(zip(a, b)):
            out += json_diff(x, y, f"{where}[{k}]")
        return out[:10]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


def h5_items(path):
    items = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            for k, v in obj.attrs.items():
                items[f"{name}@{k}"] = v
            if isinstance(obj, h5py.Dataset):
                items[name] = obj[()]
        f.visititems(visit)
        for k, v in f.attrs.items():
            items[f"@{k}"] = v
    return items


def same_value(x, y):
    if isinstance(x, bytes) or isinstance(y, bytes) or isinstance(x, str) or isinstance(y, str):
        return x == y
    x, y = np.asarray(x), np.asarray(y)
    if x.shape != y.shape or x.dtype != y.dtype:
        return False
    if x.dtype.kind == "f":
        return bool(np.all((x == y) | (np.isnan(x) & np.isnan(y))))
    return bool(np.array_equal(x, y))


def compare_h5(a, b):
    ia, ib = h5_items(a), h5_items(b)
    if set(ia) != set(ib):
        return [f"datasets differ: only in A {sorted(set(ia) - set(ib))[:5]}, only in B {sorted(set(ib) - set(ia))[:5]}"]
    out = []
    for k in sorted(ia):
        if k == "pipeline/record":
            ra, rb = (json.loads(x.decode() if isinstance(x, bytes) else x) for x in (ia[k], ib[k]))
            out += [f"{k}{d}" for d in json_diff(strip_timings(ra), strip_timings(rb))]
        elif is_timing(k.split("/")[-1].split("@")[0]):
            continue
        elif not same_value(ia[k], ib[k]):
            out.append(f"{k} differs")
    return out


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    if not rows:
        return [], []
    keep = [k for k, c in enumerate(rows[0]) if not is_timing(c)]
    return [rows[0][k] for k in keep], [[r[k] for k in keep if k < len(r)] for r in rows[1:]]


def compare_file(a, b, rel):
    if rel.endswith(".h5"):
        return compare_h5(a, b)
    if rel.endswith(".csv"):
        ca, ra = read_csv(a)
        cb, rb = read_csv(b)
        if ca != cb:
            return [f"columns {ca} != {cb}"]
        if len(ra) != len(rb):
            return [f"{len(ra)} rows != {len(rb)}"]
        return [f"row {k} differs" for k, (x, y) in enumerate(zip(ra, rb)) if x != y][:5]
    if rel.endswith(".json"):
        with open(a) as fa, open(b) as fb:
            return json_diff(strip_timings(json.load(fa)), strip_timings(json.load(fb)))
    if rel.endswith(".png"):
        return []  # the drawn data are compared through the CSVs beside them
    with open(a, "rb") as fa, open(b, "rb") as fb:
        return [] if fa.read() == fb.read() else ["text differs"]


def compare_dirs(A, B):
    fa, fb = files_of(A), files_of(B)
    problems = []
    if fa != fb:
        problems.append(f"files only in A: {sorted(fa - fb)[:10]}; only in B: {sorted(fb - fa)[:10]}")
    for rel in sorted(fa & fb):
        problems += [f"{rel}: {p}" for p in compare_file(os.path.join(A, rel), os.path.join(B, rel), rel)]
    return problems


def plot(out, log):
    cmd = ["/usr/bin/python3", "-m", "tools.plot_sps", out]
    with open(log, "w") as f:
        return subprocess.run(cmd, cwd=REPO, stdout=f, stderr=subprocess.STDOUT, env=env()).returncode


def kill_series(sparkdem, scene_file, B, wall, rng, kills_wanted, failures):
    """Runs the scene into B, killing attempts (the first fresh, the next with --resume) after
    random delays until `kills_wanted` kills or the run finished; then resumes it to its end and
    checks that a second --resume does not rerun it. Returns the number of kills."""
    kills = 0
    started = False
    name = os.path.basename(B)
    while kills < kills_wanted:
        delay = rng.uniform(0.05, 0.2) * wall
        cmd = [sparkdem, "run", scene_file, "-o", B, "--quiet"] + (["--resume"] if started else [])
        log = f"{B}_{kills}"
        rc = attempt(cmd, delay, log, B)
        with open(log + ".err") as f:
            err = f.read()
        if rc is None:
            kills += 1
            print(f"{name}: killed after {delay:.2f} s{' (resumed)' if started else ''}; {err.strip()[:200]}")
            started = True
        elif rc == 2 and "nothing to resume" in err:
            print(f"{name}: nothing to resume yet (killed before the first restart point): starting afresh")
            started = False
        elif rc == 0:
            print(f"{name}: finished before the kill ({delay:.2f} s); {err.strip()[:200]}")
            break
        else:
            failures.append(f"{name}: an attempt exited {rc}: {err.strip()[-500:]}")
            return kills
    rc = run([sparkdem, "run", scene_file, "-o", B] + (["--resume"] if started else []), B + "_last")
    with open(B + "_last.err") as f:
        last = f.read()
    print(f"{name}: last resume: exit {rc}; {last.strip()[:200]}")
    if rc != 0:
        failures.append(f"{name}: the last --resume exited {rc}: {last.strip()[-500:]}")
    # A finished run is not rerun.
    rc = run([sparkdem, "run", scene_file, "-o", B, "--resume"], B + "_again")
    with open(B + "_again.err") as f:
        again = f.read()
    if rc != 0 or "has completed" not in again:
        failures.append(f"{name}: --resume of a completed run: exit {rc}, {again.strip()[:200]}")
    return kills


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--seed", type=int, default=64)
    ap.add_argument("--kills", type=int, default=8)
    ap.add_argument("--keep", help="work in this directory and keep it")
    a = ap.parse_args()
    work = a.keep or tempfile.mkdtemp(prefix="sparkdem_resume_")
    os.makedirs(work, exist_ok=True)
    failures = []
    try:
        scene_file = os.path.join(work, "scene.json")
        with open(scene_file, "w") as f:
            json.dump(scene(), f, indent=1)
        # The scene's relative paths ($include) resolve against its directory: the configs'.
        shutil.copytree(os.path.join(REPO, "configs", "materials"), os.path.join(work, "materials"), dirs_exist_ok=True)
        A = os.path.join(work, "A")
        for d in os.listdir(work):
            if d[0] in "AB" and os.path.isdir(os.path.join(work, d)):
                shutil.rmtree(os.path.join(work, d))
        t0 = time.monotonic()
        rc = run([a.sparkdem, "run", scene_file, "-o", A, "--quiet"], os.path.join(work, "A"))
        wall = time.monotonic() - t0
        if rc != 0:
            print(f"FAIL: the uninterrupted run exited {rc}")
            return 1
        print(f"uninterrupted run: {wall:.2f} s")
        # Nothing to resume from (no such folder), and --resume with --restart: exit 2, said so.
        rc = run([a.sparkdem, "run", scene_file, "-o", os.path.join(work, "B_none"), "--resume"], os.path.join(work, "none"))
        with open(os.path.join(work, "none.err")) as f:
            err = f.read()
        if rc != 2 or "nothing to resume" not in err or os.path.exists(os.path.join(work, "B_none")):
            failures.append(f"--resume into a missing folder: exit {rc}, {err.strip()[:200]}")
        rc = run([a.sparkdem, "run", scene_file, "-o", A, "--resume", "--restart", os.path.join(A, "final_state.h5")],
                 os.path.join(work, "both"))
        if rc != 2:
            failures.append(f"--resume with --restart: exit {rc} (expected 2)")
        rng = random.Random(a.seed)
        kills = 0
        folders = []
        while kills < a.kills and len(folders) < 3:
            B = os.path.join(work, f"B{len(folders)}")
            folders.append(B)
            kills += kill_series(a.sparkdem, scene_file, B, wall, rng, a.kills - kills, failures)
        if kills < a.kills:
            failures.append(f"only {kills} attempts were killed")
        for d in [A] + folders:
            if plot(d, d + "_plot.log") != 0:
                failures.append(f"tools.plot_sps failed on {d} (see {d}_plot.log)")
        ROOTS.extend(os.path.realpath(d) for d in [A] + folders)
        for B in folders:
            failures += [f"{os.path.basename(B)}: {p}" for p in compare_dirs(A, B)[:40]]
        print(f"{kills} kills in {len(folders)} folder(s); compared {len(files_of(A))} files each")
    finally:
        if not a.keep and not failures:
            shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    if failures and not a.keep:
        print(f"(work directory kept: {work})")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
