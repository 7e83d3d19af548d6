#!/usr/bin/python3
"""Sweeps over MPI ranks: wall time and efficiency at 1 and 2 ranks (issue 24 item 3).

    /usr/bin/python3 benchmarks/ranks/run.py [--sparkdem build/sparkdem] [--scenes A.json,B.json]
                                             [--ranks 1,2] [--workdir /tmp/sparkdem_ranks]

runs each scene once per rank count (one OpenMP thread per rank, OMP_WAIT_POLICY=PASSIVE, rank
counts interleaved scene by scene), checks that every sweep table equals the one-rank run's
(wall-clock columns left out) and writes benchmarks/ranks/results.csv: per scene and rank count
the whole run's wall time, the sweep stages' wall time (the part spread over the ranks; the other
stages run on rank 0), their speed-ups and efficiencies (speed-up / ranks) against one rank.
Default scenes: configs/cpc_percolation.json (12 sweep stages of 10 items) and
configs/sps_nial_small.json (pack, hot press, then three conductivity sweeps over its snapshots,
one of them calibrating).
"""
import argparse
import csv
import json
import os
import subprocess
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def wall_clock(column):
    return column.endswith("solve_time") or "wall_time" in column


def tables(out):
    res = {}
    for p in sorted(out.glob("sweep_*.csv")):
        with open(p) as f:
            rows = list(csv.reader(f))
        keep = [k for k, c in enumerate(rows[0]) if not wall_clock(c)]
        res[p.name] = [[r[k].replace(str(out), "OUT") for k in keep] for r in rows]
    return res


def one_run(a, scene, ranks, out):
    cmd = ([] if ranks == 1 else ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks)])
    cmd += [a.sparkdem, "run", str(scene), "-o", str(out), "--quiet", "--threads", "1"]
    env = dict(os.environ, OMP_WAIT_POLICY="PASSIVE", OMP_NUM_THREADS="1")
    subprocess.run(["rm", "-rf", str(out)], check=True)
    t0 = time.time()
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
    wall = time.time() - t0
    s = json.loads((out / "summary.json").read_text())
    sweep = sum(st.get("wall_time_s", 0.0) for st in s["stages"] if "sweep" in st)
    items = sum(st["sweep"]["items"] for st in s["stages"] if "sweep" in st)
    return {"wall_s": wall, "sweep_wall_s": sweep, "items": items, "tables": tables(out)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", default=str(ROOT / "build" / "sparkdem"))
    ap.add_argument("--scenes", default="configs/cpc_percolation.json,configs/sps_nial_small.json")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--workdir", default="/tmp/sparkdem_ranks")
    ap.add_argument("--out", default=str(HERE / "results.csv"))
    a = ap.parse_args()
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    load = os.getloadavg()[0]
    rows = []
    for scene in a.scenes.split(","):
        path = ROOT / scene
        runs = {}
        for n in (int(x) for x in a.ranks.split(",")):
            runs[n] = one_run(a, path, n, Path(a.workdir) / f"{path.stem}_{n}")
            print(f"{scene} {n} rank(s): {runs[n]['wall_s']:.2f} s, sweeps {runs[n]['sweep_wall_s']:.2f} s", flush=True)
        base = runs[min(runs)]
        for n, r in runs.items():
            rows.append({"scene": scene, "ranks": n, "threads_per_rank": 1, "sweep_items": r["items"],
                         "wall_s": f"{r['wall_s']:.3f}", "sweep_wall_s": f"{r['sweep_wall_s']:.3f}",
                         "speedup": f"{base['wall_s'] / r['wall_s']:.3f}",
                         "efficiency": f"{base['wall_s'] / r['wall_s'] / n:.3f}",
                         "sweep_speedup": f"{base['sweep_wall_s'] / r['sweep_wall_s']:.3f}",
                         "sweep_efficiency": f"{base['sweep_wall_s'] / r['sweep_wall_s'] / n:.3f}",
                         "tables_equal_to_1_rank": r["tables"] == base["tables"],
                         "commit": commit, "load_average_at_start": f"{load:.2f}"})
    with open(a.out + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(a.out + ".tmp", a.out)


if __name__ == "__main__":
    main()
