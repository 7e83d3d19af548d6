#!/usr/bin/python3
"""Sweeps over MPI ranks against the one-rank run (issue 24 items 1 and 5; ctest label "mpi").

    test_mpi_sweeps.py CASE --sparkdem BIN [--mpirun MPIRUN] [--workdir DIR]

CASE:
  equal      configs/sweep_example.json (a seed ensemble, a parameter sweep, a sweep over
             snapshots) and a calibrating sweep (scan, search, validation) on 1 rank and on 2:
             the sweep tables, the summary's sweep entries (rows, statistics, calibration) and
             every item's final state (every dataset but /pipeline/record, which records the
             sweep's progress when the item ran) are identical.
  bad_input  a scene with two errors under mpirun: exit code 2 from every rank, each error
             printed once (by rank 0), no hang (60 s limit).
  restart    a seed ensemble on 2 ranks killed (SIGKILL, every rank) after its second row,
             restarted with --restart on 1 rank; a one-rank run killed inside an item,
             restarted on 2 ranks; and 2 ranks killed, continued with --resume on 2 ranks:
             every table equals the uninterrupted run's.
  spread_solve  the spread network solve (tests/mpi/mpi_spread_solve.cpp) under mpirun -np 2:
             Amg over 2 ranks and on rank 0 alone against the direct solve, to 1e-7; and through
             sparkdem: a 1000-sphere lattice's electrical_network (solver amg, spread threshold
             100 rows) in a dynamics stage on 2 ranks reports electrical_amg_ranks 2 (1 on one
             rank), its resistance within 1e-9 of the one-rank run's and of the direct solve's.
Exit code 0 when every check holds; the failed checks are printed.
"""
import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FAILED = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        FAILED.append(what)


def mpirun_cmd(a, n):
    return [a.mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(n)]


def run(a, scene, out, ranks=1, extra=(), timeout=120, wait=True):
    cmd = ([] if ranks == 1 else mpirun_cmd(a, ranks)) + [a.sparkdem, "run", str(scene), "-o", str(out), "--quiet",
                                                          "--threads", "1", *extra]
    if not wait:
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def wall_clock(column):
    """Columns that time the run itself (no two runs share them, on any number of ranks)."""
    return column.endswith("solve_time") or "wall_time" in column


def table(path, out):
    """The CSV's rows, paths inside `out` made relative, wall-clock columns left out."""
    with open(path) as f:
        rows = list(csv.reader(f))
    keep = [k for k, c in enumerate(rows[0]) if not wall_clock(c)] if rows else []
    return [[row[k].replace(str(out), "OUT") for k in keep] for row in rows]


def sweep_entries(out):
    s = json.loads((out / "summary.json").read_text())
    entries = {}
    for e in s["stages"]:
        if "sweep" in e:
            x = json.loads(json.dumps(e["sweep"]).replace(str(out), "OUT"))
            for r in x.get("rows", []):
                r["values"] = {k: v for k, v in r.get("values", {}).items() if not wall_clock(k)}
            x["statistics"] = {k: v for k, v in x.get("statistics", {}).items() if not wall_clock(k)}
            x["columns"] = [c for c in x.get("columns", []) if not wall_clock(c)]
            entries[e["name"]] = x
    return entries


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name != "pipeline/record":
                out[name] = obj[()]
        f.visititems(visit)
    return out


def same_state(p, q):
    a, b = datasets(p), datasets(q)
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.shape != y.shape:
            return False
        if x.dtype.kind == "O" or y.dtype.kind == "O":  # strings: by value
            if x.tolist() != y.tolist():
                return False
        elif x.tobytes() != y.tobytes():  # numbers: bit for bit (NaN included)
            return False
    return True


def calibration_scene(tmp):
    """The calibrating sweep of tests/scenario/test_sweeps.cpp (scan, search, validation)."""
    return ROOT / "tests" / "scenario" / "data" / "sweep_calibrate_chain.json"


def compare_runs(one, two, label):
    names = sorted(p.name for p in one.glob("sweep_*.csv"))
    check(names == sorted(p.name for p in two.glob("sweep_*.csv")) and names, f"{label}: the same sweep tables {names}")
    for n in names:
        check(table(one / n, one) == table(two / n, two), f"{label}: {n} identical")
    check(sweep_entries(one) == sweep_entries(two), f"{label}: summary sweep entries identical (rows, statistics, calibration)")
    items = sorted(one.glob("sweep_*/*/final_state.h5"))
    same = [same_state(p, two / p.relative_to(one)) for p in items]
    check(items and all(same), f"{label}: {sum(same)} of {len(items)} item final states identical (but /pipeline/record)")


def case_equal(a, tmp):
    for scene in (ROOT / "configs" / "sweep_example.json", calibration_scene(tmp)):
        one, two = tmp / (scene.stem + "_1"), tmp / (scene.stem + "_2")
        t0 = time.time()
        r1 = run(a, scene, one)
        t1 = time.time()
        r2 = run(a, scene, two, ranks=2)
        t2 = time.time()
        check(r1.returncode == 0 and r2.returncode == 0,
              f"{scene.name}: both runs exit 0 ({r1.returncode}, {r2.returncode}) {r1.stderr[-300:]} {r2.stderr[-300:]}")
        print(f"      {scene.name}: 1 rank {t1 - t0:.2f} s, 2 ranks {t2 - t1:.2f} s")
        compare_runs(one, two, scene.name)
        log = (two / "run.log").read_text()
        check(log.count("run started") == 1, f"{scene.name}: one run.log line 'run started' (rank 0 only)")


def case_bad_input(a, tmp):
    scene = json.loads((ROOT / "configs" / "sweep_example.json").read_text())
    scene["stages"][0]["dt"] = -1.0
    scene["stages"][1]["generator"]["particles"] = "many"
    p = tmp / "bad.json"
    p.write_text(json.dumps(scene))
    t0 = time.time()
    try:
        r = run(a, p, tmp / "bad_out", ranks=2, timeout=60)
    except subprocess.TimeoutExpired:
        check(False, "bad input under mpirun: finished within 60 s")
        return
    err = r.stderr
    print(f"      exit {r.returncode} after {time.time() - t0:.2f} s; stderr:\n" + "\n".join("        " + l for l in err.splitlines()[:12]))
    check(r.returncode == 2, f"bad input under mpirun: exit code 2 (got {r.returncode})")
    check(err.count("3 configuration error(s)") == 1, "the error report printed once (by rank 0)")
    check(err.count("/stages/0/dt: expected a value >= 0") == 1, "the dt error (path /stages/0/dt) printed once")
    check(err.count("/stages/1/generator/particles") == 1, "the particles error printed once")


def ensemble_scene(tmp):
    scene = json.loads((ROOT / "tests" / "scenario" / "data" / "sweep_fill_ensemble.json").read_text())
    st = scene["stages"][0]
    st["generator"]["particles"] = 150
    st["generator"]["ke_per_mass_below"] = 1e-12  # runs to its step budget
    st["stop"]["steps"] = 20000  # each item long enough to be killed inside (checkpoints every 1000 steps)
    st["output"]["checkpoint_every"] = 1000
    st["sweep"]["seeds"] = [1, 2, 3, 4, 5, 6]
    p = tmp / "ensemble.json"
    p.write_text(json.dumps(scene))
    return p


def rows_of(out):
    f = out / "sweep_cook.csv"
    return max(0, len(table(f, out)) - 1) if f.exists() else 0


def kill_when(proc, out, rows, limit=60.0, inside_item=False):
    """SIGKILL the run's whole process group once the table has `rows` rows (and, when
    `inside_item`, the next item has written a checkpoint)."""
    t0 = time.time()
    while time.time() - t0 < limit and proc.poll() is None:
        ready = rows_of(out) >= rows
        if ready and inside_item:
            ready = (out / "sweep_cook" / str(rows) / "run.log").exists() and "checkpoint written" in \
                (out / "sweep_cook" / str(rows) / "run.log").read_text()
        if ready:
            # The launcher's process group, then every rank (Open MPI starts them in their own
            # groups: they would otherwise go on writing into `out`), as a machine failure would.
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            subprocess.run(["pkill", "-9", "-f", str(out)], check=False)
            while subprocess.run(["pgrep", "-f", str(out)], capture_output=True).returncode == 0:
                time.sleep(0.02)
            return True
        time.sleep(0.02)
    return False


def case_restart(a, tmp):
    scene = ensemble_scene(tmp)
    ref = tmp / "ens_ref"
    t0 = time.time()
    r = run(a, scene, ref)
    check(r.returncode == 0, f"uninterrupted ensemble exits 0 ({time.time() - t0:.2f} s)")
    # 2 ranks killed after two rows, restarted on 1 rank.
    out = tmp / "ens_a"
    killed = kill_when(run(a, scene, out, ranks=2, wait=False), out, 2)
    n = rows_of(out)
    check(killed and 2 <= n < 6, f"2-rank run killed with {n} of 6 rows")
    r = run(a, scene, out, extra=("--restart", str(out / "checkpoint.h5")))
    check(r.returncode == 0, f"1-rank restart exits 0 {r.stderr[-300:]}")
    check(table(out / "sweep_cook.csv", out) == table(ref / "sweep_cook.csv", ref), "2 ranks killed, 1-rank restart: table equals the uninterrupted run's")
    # 1 rank killed inside an item, restarted on 2 ranks.
    out = tmp / "ens_b"
    killed = kill_when(run(a, scene, out, wait=False), out, 2, inside_item=True)
    check(killed, f"1-rank run killed inside item 2 ({rows_of(out)} rows)")
    r = run(a, scene, out, ranks=2, extra=("--restart", str(out / "checkpoint.h5")))
    check(r.returncode == 0, f"2-rank restart exits 0 {r.stderr[-300:]}")
    check(table(out / "sweep_cook.csv", out) == table(ref / "sweep_cook.csv", ref), "1 rank killed, 2-rank restart: table equals the uninterrupted run's")
    # 2 ranks killed after two rows, continued in place with --resume on 2 ranks (issue 64): the
    # newest restart point (the checkpoint with the finished rows) is found, and the folder ends as
    # the uninterrupted run's (tables, summary sweep entries, item final states).
    out = tmp / "ens_c"
    killed = kill_when(run(a, scene, out, ranks=2, wait=False), out, 2)
    check(killed, f"2-rank run killed with {rows_of(out)} of 6 rows")
    r = run(a, scene, out, ranks=2, extra=("--resume",))
    check(r.returncode == 0 and "resuming from checkpoint" in r.stderr, f"2-rank --resume exits 0 from a checkpoint: {r.stderr[-300:]}")
    compare_runs(ref, out, "2 ranks killed, --resume on 2 ranks")
    r = run(a, scene, out, ranks=2, extra=("--resume",))
    check(r.returncode == 0 and "has completed" in r.stderr, f"a second --resume does not rerun the completed run: {r.stderr[-200:]}")


def case_spread_solve(a, tmp):
    r = subprocess.run(mpirun_cmd(a, 2) + [a.spread_solve], capture_output=True, text=True, timeout=120)
    print("\n".join("      " + l for l in r.stdout.splitlines()))
    check(r.returncode == 0 and "FAIL" not in r.stdout and r.stdout.count("ok") >= 8,
          f"spread solve driver: exit {r.returncode}, every check ok {r.stderr[-300:]}")
    amg, direct = lattice_network_scene(tmp, "amg"), lattice_network_scene(tmp, "direct")
    runs = {"amg_1": run(a, amg, tmp / "amg_1"), "amg_2": run(a, amg, tmp / "amg_2", ranks=2),
            "direct": run(a, direct, tmp / "direct")}
    check(all(r.returncode == 0 for r in runs.values()),
          "lattice network runs exit 0 " + " ".join(r.stderr[-200:] for r in runs.values()))
    rows = {k: final_row(tmp / k) for k in runs}
    check(float(rows["amg_1"]["electrical_amg_ranks"]) == 1 and float(rows["amg_2"]["electrical_amg_ranks"]) == 2,
          f"electrical_amg_ranks: {rows['amg_1']['electrical_amg_ranks']} on 1 rank, {rows['amg_2']['electrical_amg_ranks']} on 2")
    r1, r2, rd = (float(rows[k]["electrical_resistance"]) for k in ("amg_1", "amg_2", "direct"))
    check(abs(r2 / r1 - 1) <= 1e-9 and abs(r2 / rd - 1) <= 1e-9,
          f"resistance on 2 ranks {r2!r} vs 1 rank {r1!r} and direct {rd!r} (1e-9)")


def lattice_network_scene(tmp, solver):
    scene = {
        "name": "lattice_network", "materials": [{"name": "m", "density": 8000}],
        "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": 1e9}},
        "particle_sets": {"top": {"type": "top_layer", "thickness": 0.001},
                          "bottom": {"type": "bottom_layer", "thickness": 0.001}},
        "stages": [
            {"name": "block", "type": "lattice",
             "generator": {"lo": [0, 0, 0], "hi": [0.0199, 0.0199, 0.0199], "spacing": 0.00199, "diameter": 0.002}},
            {"name": "measure", "type": "dynamics", "dt_fraction": 0.1, "sets": ["top", "bottom"],
             "modules": {"electrical_network": {"model": "holm", "conductivity": 1e6, "high": "top", "low": "bottom",
                                                "voltage": 0.5, "solver": solver, "tolerance": 1e-12,
                                                **({"amg_spread_min_rows": 100} if solver == "amg" else {})}},
             "stop": {"steps": 2}}]}
    p = tmp / f"lattice_network_{solver}.json"
    p.write_text(json.dumps(scene))
    return p


def final_row(out):
    with open(out / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    return rows[-1]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("case", choices=["equal", "bad_input", "restart", "spread_solve"])
    ap.add_argument("--spread-solve", help="the mpi_spread_solve driver (case spread_solve)")
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--mpirun", default="mpirun")
    ap.add_argument("--workdir", default="mpi_tests")
    a = ap.parse_args()
    tmp = Path(a.workdir).resolve() / a.case
    subprocess.run(["rm", "-rf", str(tmp)], check=True)
    tmp.mkdir(parents=True)
    {"equal": case_equal, "bad_input": case_bad_input, "restart": case_restart,
     "spread_solve": case_spread_solve}[a.case](a, tmp)
    print(f"{a.case}: {len(FAILED)} check(s) failed" if FAILED else f"{a.case}: all checks hold")
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main())
