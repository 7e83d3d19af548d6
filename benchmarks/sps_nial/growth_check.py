#!/usr/bin/python3
"""Issue 36 item 4, physics track: what Arzt's mass-conserving radii (module mass_conserving_radii)
change in the quasi-static hot press of the 300-particle NiAl compact.

Runs each scene (default: the quasi-static hot press without growth and the same with growth,
benchmarks/sps_nial/issue36/) on each packing seed, one thread per run, two runs at a time, and
writes one row per scene, seed and porosity target (the first time-series row of the hot press at
or below the target's porosity by mass; 'end' for the last row):

  porosity_mass, porosity_body (the union of the spheres less their lenses: the body the spheres
  stand for), body_minus_mass, core_minus_compact (porosity_mass_interior - porosity_mass),
  neck_max_bin_percent, neck_last_bin_percent, neck_median_a_over_rmin, growth_mean, growth_max,
  growth_capped, growth_dense, growth_missing_volume (empty without the module), time_s, and per run
  its exit code and the first line of its error.

    python3 -m benchmarks.sps_nial.growth_check --sparkdem BIN --workdir DIR [--seeds 2024,2025,2026]
        [--scenes A.json,B.json] [--csv benchmarks/sps_nial/issue36/growth/growth_check.csv]
"""
import argparse
import concurrent.futures
import csv
import json
import os
import subprocess

from benchmarks.perf.harness import write_csv_atomic
from tools import sps_outputs as so

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = ("benchmarks/sps_nial/issue36/sps_nial_small_quasi_static_mean.json",
          "benchmarks/sps_nial/issue36/sps_nial_small_quasi_static_growth.json")
TARGETS = (0.30, 0.216, 0.164, 0.106, 0.05)
COLUMNS = ("porosity_mass", "porosity", "porosity_mass_interior", "neck_max_bin_percent", "neck_last_bin_percent",
           "neck_median_a_over_rmin", "growth_mean", "growth_max", "growth_capped", "growth_dense", "growth_missing_volume")


def run(sparkdem, workdir, scene, seed):
    path = os.path.join(REPO, scene)
    with open(path) as f:
        c = json.load(f)
    so.absolute_includes(c, os.path.dirname(path))
    c["seed"] = seed
    name = f"{os.path.splitext(os.path.basename(scene))[0]}_{seed}"
    os.makedirs(workdir, exist_ok=True)
    scene_file = os.path.join(workdir, name + ".json")
    with open(scene_file, "w") as f:
        json.dump(c, f, indent=1)
    out = os.path.join(workdir, name)
    p = subprocess.run([sparkdem, "run", scene_file, "-o", out, "--threads", "1", "--quiet"], capture_output=True, text=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    error = p.stderr.strip().splitlines()[0][:300] if p.returncode else ""
    stage = str(next(k for k, st in enumerate(c["stages"]) if st["name"] == "hot_press"))  # the column holds the stage index
    with open(os.path.join(out, "timeseries.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r.get("stage") == stage]
    return scene, seed, p.returncode, error, rows


def value(row, key):
    v = row.get(key, "")
    return float(v) if v not in ("", None) else None


def table(scene, seed, code, error, rows):
    picks = []
    for target in TARGETS:
        hit = next((r for r in rows if (value(r, "porosity_mass") or 1.0) <= target), None)
        if hit is not None:
            picks.append((f"{target:g}", hit))
    if rows:
        picks.append(("end", rows[-1]))
    out = []
    for label, r in picks:
        v = {k: value(r, k) for k in COLUMNS}
        mass, body, core = v["porosity_mass"], v["porosity"], v["porosity_mass_interior"]
        out.append({
            "scene": os.path.basename(scene), "seed": seed, "target": label, "time_s": value(r, "physical_time") or value(r, "time"),
            "porosity_mass": mass, "porosity_body": body,
            "body_minus_mass": body - mass if body is not None and mass is not None else None,
            "core_minus_compact": core - mass if core is not None and mass is not None else None,
            **{k: v[k] for k in COLUMNS[3:]}, "exit_code": code, "error": error})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--seeds", default="2024,2025,2026")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--csv", default=os.path.join(REPO, "benchmarks/sps_nial/issue36/growth/growth_check.csv"))
    a = ap.parse_args()
    jobs = [(s, int(seed)) for s in a.scenes.split(",") for seed in a.seeds.split(",")]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        results = list(ex.map(lambda j: run(os.path.abspath(a.sparkdem), a.workdir, *j), jobs))
    rows = [row for res in results for row in table(*res)]
    os.makedirs(os.path.dirname(os.path.abspath(a.csv)), exist_ok=True)
    write_csv_atomic(a.csv, rows)
    for r in rows:
        print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items() if k != "error"))


if __name__ == "__main__":
    main()
