#!/usr/bin/python3
"""Issue 59 item 2: why does the hot press densify the interior and not the rim (gate G1)?

The reduced pipeline (configs/sps_nial_small.json) with the inertia-free hot press of issue 36
(benchmarks/sps_nial/issue36/sps_nial_small_quasi_static_mean.json) at `--size` x the particles
(the die and the bed scaled by size^(1/3), benchmarks/sps_nial/step_halving.scene), run once per
variant of the hot press's sintering law, everything else as configured:

  as_configured   the law as the scenario has it
  no_sintering    surface_energy 0: no sintering force F_s, the punch's 30 MPa alone creeps the necks
  no_friction     friction 0 and wall_friction 0 (contacts without a neck, and the die and punches)

Per snapshot it writes issue 59's gates (tools/sps_outputs.uniform_press_gates: G1 the interior /
whole relative-density ratio's rise over the packing's, G2 the envelope over the die radius, G4 the
network's necks) with the porosity taken and the time the press took to reach it.

    python3 -m benchmarks.sps_nial.uniformity_mechanism --sparkdem BIN --workdir DIR
        [--size 4] [--seed 2024] [--variants as_configured,no_sintering,no_friction] [--jobs 2]
        [--csv benchmarks/sps_nial/uniformity_mechanism.csv]
"""
import argparse
import concurrent.futures
import json
import os
import subprocess

from benchmarks.perf.harness import write_csv_atomic
from benchmarks.sps_nial.step_halving import scene
from tools import sps_outputs as so

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HOT_PRESS = "benchmarks/sps_nial/issue36/sps_nial_small_quasi_static_mean.json"
VARIANTS = {"as_configured": {}, "no_sintering": {"surface_energy": 0.0}, "no_friction": {"friction": 0.0, "wall_friction": 0.0}}


def variant_scene(seed, size, variant):
    c = scene("configs/sps_nial_small.json", seed, 1.0, os.path.join(REPO, HOT_PRESS), size)
    hp = next(st for st in c["stages"] if st["name"] == "hot_press")
    hp["contact"]["params"].update(VARIANTS[variant])
    return c


def run(sparkdem, workdir, seed, size, variant):
    out = os.path.join(workdir, f"{variant}_s{seed}_x{size:g}")
    path = out + ".json"
    with open(path, "w") as f:
        json.dump(variant_scene(seed, size, variant), f, indent=1)
    subprocess.run([sparkdem, "run", path, "-o", out, "--threads", "1", "--quiet"], check=True,
                   env=dict(os.environ, OMP_NUM_THREADS="1"))
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    gates = so.uniform_press_gates(out, s)
    taken = {t["index"]: t for t in so.find_stage(s, "hot_press").get("snapshots", {}).get("taken", [])}
    rows = []
    for k in sorted(t for t in gates if t != "median_rises"):
        g = gates[k]
        rows.append({"variant": variant, "seed": seed, "size": size, "snapshot": k, "target": taken[k].get("target"),
                     "porosity_taken": taken[k]["value"], "press_time_s": taken[k].get("time"),
                     **{n: g[n] for n in ("g1_density_ratio_rise", "g1_density_ratio", "g1_density_ratio_packing",
                                          "g2_envelope_p995_over_die", "g4_network_neck_last_bin_percent",
                                          "network_neck_median_a_over_rmin", "network_neck_gbf_bound_share")},
                     "median_rises": gates["median_rises"],
                     "hot_press_wall_s": so.find_stage(s, "hot_press")["wall_time_s"]})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--size", type=float, default=4.0)
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--csv", default=os.path.join(REPO, "benchmarks/sps_nial/uniformity_mechanism.csv"))
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        parts = list(ex.map(lambda v: run(os.path.abspath(a.sparkdem), a.workdir, a.seed, a.size, v), a.variants.split(",")))
    rows = [r for p in parts for r in p]
    write_csv_atomic(a.csv, rows)
    for r in rows:
        print(f"{r['variant']:14s} p {r['porosity_taken']:.3f}  G1 rise {r['g1_density_ratio_rise']:+.4f}  "
              f"G2 {r['g2_envelope_p995_over_die']:.4f}  G4 last {r['g4_network_neck_last_bin_percent']}")


if __name__ == "__main__":
    main()
