#!/usr/bin/env python3
"""Bit-identity guard for refactors: each shipped config's short variant, run, digested.

For every scenario file configs/*.json this tool writes a *short variant* (the same stages, keys,
laws, modules, walls and sets, with every stepping stage capped at STEPS steps, every generator
capped at PARTICLES particles (a generator given a box and a volume fraction, as cpc_fillers, gets
the edge that holds PARTICLES) and RELAX_ITERATIONS relaxation iterations, every sweep cut to its
first two items), runs it with `sparkdem run --threads 1`, and digests

  * the resolved scenario that `sparkdem check` prints for the *full* config (every key as parsed),
  * every HDF5 dataset of every *.h5 file the short run wrote (final state, results, snapshots,
    sweep items; datasets read with h5py, raw bytes and shape), and
  * every sweep table (sweep_*.csv) without its timing columns.

Wall-clock timings are left out: they are not results (summary.json, the run records of
`pipeline/record`, every dataset or column named *wall_time* or *solve_time*).

    python3 -m tools.config_digest make  --sparkdem BUILD/sparkdem   # writes tests/reference/config_digests.json
    python3 -m tools.config_digest make  --sparkdem BUILD/sparkdem --config NAME.json ...
                                     # remakes those entries only (a change meant to alter their results)
    python3 -m tools.config_digest check --sparkdem BUILD/sparkdem [--config NAME]   # exit 1 on any difference

`make` is run on a clean commit whose results are the reference (the file records the commit);
`check` (ctest `configs_bit_identical/<name>`) compares a build against it. A change that alters
results on purpose regenerates the file with `make` and says so in its commit.
"""
import argparse
import csv
import glob
import hashlib
import io
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = os.path.join(REPO, "configs")
REFERENCE = os.path.join(REPO, "tests", "reference", "config_digests.json")
STEPS = 40
PARTICLES = 300
RELAX_ITERATIONS = 200
SWEEP_ITEMS = 2
TIMEOUT_S = 30  # `check` fails a short variant slower than this (on one thread): CI's limit per test
# `make` records a short variant slower than this as skipped (never run by `check`): a third of
# TIMEOUT_S, because two CI tests share the two cores and a loaded machine runs a variant 1.7x slower
# than an idle one (cpc_ptc_temperature: 18 s alone, 30 s in CI at 598 s, stop 55).
MAKE_LIMIT_S = 10


def cap_box_length(gen):
    """A generator that fills a cube of edge box_length to a volume fraction (cpc_fillers: N =
    phi L^3 / (4/3 pi R^3)) gets the edge whose cube holds PARTICLES spheres, if it is shorter."""
    keys = ("box_length", "volume_fraction", "radius")
    if not all(isinstance(gen.get(k), (int, float)) and gen[k] > 0 for k in keys):
        return
    edge = (PARTICLES * 4.0 / 3.0 * math.pi * gen["radius"] ** 3 / gen["volume_fraction"]) ** (1.0 / 3.0)
    gen["box_length"] = min(gen["box_length"], float(f"{edge:.4g}"))


def short_variant(scene):
    """The short variant of a scenario (a dict); rules in the module docstring."""
    for stage in scene.get("stages", []):
        stop = stage.setdefault("stop", {})
        if stop.get("steps", STEPS + 1) > STEPS:
            stop["steps"] = STEPS
        gen = stage.get("generator")
        if isinstance(gen, dict):
            if isinstance(gen.get("particles"), int):
                gen["particles"] = min(gen["particles"], PARTICLES)
            cap_box_length(gen)
            if isinstance(gen.get("max_iterations"), int):
                gen["max_iterations"] = min(gen["max_iterations"], RELAX_ITERATIONS)
        sweep = stage.get("sweep")
        if isinstance(sweep, dict):
            for key in ("values", "seeds"):
                if isinstance(sweep.get(key), list):
                    sweep[key] = sweep[key][:SWEEP_ITEMS]
            cal = sweep.get("calibrate")
            if isinstance(cal, dict) and isinstance(cal.get("max_iterations"), int):
                cal["max_iterations"] = min(cal["max_iterations"], 1)
    return scene


def is_timing(name):
    """Does a dataset or column hold wall-clock timings (which differ run to run)?"""
    return name == "pipeline/record" or "wall_time" in name or "solve_time" in name


def h5_digest(path, h):
    import h5py
    import numpy as np

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and not is_timing(name):
            data = obj[()]
            arr = np.asarray(data)
            h.update(name.encode())
            h.update(str(arr.shape).encode())
            if arr.dtype.kind in "OSU":
                h.update(repr(arr.tolist()).encode())
            else:
                h.update(np.ascontiguousarray(arr).tobytes())

    with h5py.File(path, "r") as f:
        f.visititems(visit)


def csv_digest(path, h):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return
    keep = [k for k, c in enumerate(rows[0]) if not is_timing(c)]
    for row in rows:
        h.update(("|".join(row[k] for k in keep if k < len(row)) + "\n").encode())


def output_digest(outdir):
    h = hashlib.sha256()
    for path in sorted(glob.glob(os.path.join(outdir, "**", "*"), recursive=True)):
        rel = os.path.relpath(path, outdir)
        if path.endswith(".h5"):
            h.update(rel.encode())
            h5_digest(path, h)
        elif os.path.basename(path).startswith("sweep_") and path.endswith(".csv"):
            h.update(rel.encode())
            csv_digest(path, h)
    return h.hexdigest()


def resolved_digest(sparkdem, config):
    p = subprocess.run([sparkdem, "check", config], capture_output=True, text=True, cwd=REPO)
    return hashlib.sha256((str(p.returncode) + "\n" + p.stdout).encode()).hexdigest()


def digest_config(sparkdem, name, workdir, limit_s=TIMEOUT_S):
    """{'check': digest of the resolved full config, 'run': digest of the short run, 'exit': code},
    or {'skipped': why} when the short run takes over limit_s seconds."""
    config = os.path.join(CONFIGS, name)
    # The variant sits in a copy of configs/ so that includes and CSV paths resolve as in the original.
    tree = os.path.join(workdir, "configs")
    if not os.path.isdir(tree):
        shutil.copytree(CONFIGS, tree)
    with open(config) as f:
        scene = json.load(f)
    variant = os.path.join(tree, "short_" + name)
    with open(variant, "w") as f:
        json.dump(short_variant(scene), f, indent=1)
    outdir = os.path.join(workdir, "out_" + name[:-5])
    shutil.rmtree(outdir, ignore_errors=True)
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
    t0 = time.monotonic()
    try:
        p = subprocess.run([sparkdem, "run", "--threads", "1", "--quiet", "--report-only", "-o", outdir, variant],
                           capture_output=True, text=True, env=env, cwd=workdir, timeout=limit_s)
    except subprocess.TimeoutExpired:
        p = None
    if p is None or time.monotonic() - t0 > limit_s:
        return {"skipped": f"the short variant runs over {limit_s} s on one thread"}
    return {"check": resolved_digest(sparkdem, config), "exit": p.returncode,
            "run": output_digest(outdir) if os.path.isdir(outdir) else "",
            "stderr_tail": p.stderr.strip().splitlines()[-1:] if p.returncode else []}


def shipped_configs():
    return sorted(os.path.basename(p) for p in glob.glob(os.path.join(CONFIGS, "*.json")))


def commit_of(sparkdem):
    p = subprocess.run([sparkdem, "--version"], capture_output=True, text=True)
    return p.stdout.strip()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["make", "check"])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--config", action="append", help="configs/NAME.json (default: every shipped config)")
    ap.add_argument("--workdir", help="scratch directory (default: a temporary one)")
    a = ap.parse_args(argv)
    names = a.config or shipped_configs()
    workdir = a.workdir or tempfile.mkdtemp(prefix="config_digest_")
    os.makedirs(workdir, exist_ok=True)
    got = {}
    ref = None
    if a.command == "check":
        with open(REFERENCE) as f:
            ref = json.load(f)["configs"]
    for name in names:
        if ref is not None and "skipped" in ref.get(name, {}):
            print(f"{name}: skipped ({ref[name]['skipped']})", flush=True)
            continue
        got[name] = digest_config(a.sparkdem, name, workdir, MAKE_LIMIT_S if a.command == "make" else TIMEOUT_S)
        g = got[name]
        print(f"{name}: " + (g["skipped"] if "skipped" in g else
                             f"exit {g['exit']} run {g['run'][:12]} check {g['check'][:12]}"), flush=True)
    if a.command == "make":
        rules = {"steps": STEPS, "particles": PARTICLES, "relax_iterations": RELAX_ITERATIONS, "sweep_items": SWEEP_ITEMS,
                 "box_length_particles": PARTICLES, "make_limit_s": MAKE_LIMIT_S}
        if a.config:
            # Remake only the named configs (a change meant to alter their results): the other entries
            # keep theirs; each remade entry names the binary that made it.
            with open(REFERENCE) as f:
                ref = json.load(f)
            if ref.get("rules") != rules:
                raise SystemExit("config_digest: the reference was made with other rules; remake every config")
            for name, g in got.items():
                ref["configs"][name] = dict(g, binary=commit_of(a.sparkdem))
        else:
            ref = {"made_by": "tools/config_digest.py make", "binary": commit_of(a.sparkdem), "rules": rules, "configs": got}
        tmp = REFERENCE + ".tmp"
        with open(tmp, "w") as f:
            json.dump(ref, f, indent=1, sort_keys=True)
            f.write("\n")
        os.replace(tmp, REFERENCE)
        print("wrote", os.path.relpath(REFERENCE, REPO))
        return 0
    bad = 0
    for name, g in got.items():
        r = ref.get(name)
        if r is None:
            print(f"{name}: no reference (run `python3 -m tools.config_digest make` on a clean commit)")
            bad += 1
            continue
        for key in ("exit", "run", "check", "skipped"):
            if g.get(key) != r.get(key):
                print(f"{name}: {key} differs from the reference ({r.get(key)!r} -> {g.get(key)!r}); stderr: {g.get('stderr_tail')}")
                bad += 1
    if not a.workdir:
        shutil.rmtree(workdir, ignore_errors=True)
    if bad:
        return 1
    return 77 if not got else 0  # every config asked for is skipped in the reference (ctest: skipped)


if __name__ == "__main__":
    sys.exit(main())
