#!/usr/bin/python3
"""Issue 36 item 5's last gate: does kappa move less than 1 % when the hot press's step is halved?
Runs a pipeline config (default configs/sps_nial_small.json, without its cooled_conductivity stage)
twice, the hot_press (and heat) stages at their step and at half of it, everything else unchanged,
and writes per snapshot: the porosity taken, kappa_eff without and with the grain-boundary layer
(the layer calibrated on 0.164 in each run), their relative change at the half step, and the
snapshot's quasi-static gates (tools/sps_outputs.quasi_static_gates).

The step of an explicit stage is its dt_fraction. With --hot-press FILE the config's hot_press stage
is replaced by FILE's (e.g. the quasi-static one of benchmarks/sps_nial/issue36/); the step of a
quasi-static stage is its dt and all three of its increment limits (max_strain_increment,
max_approach_increment, max_mean_strain_increment), halved together.

    python3 -m benchmarks.sps_nial.step_halving --sparkdem build/sparkdem --workdir DIR
        [--config configs/sps_nial_small.json] [--hot-press FILE] [--seed 2024] [--factors 1,0.5] [--size 1]
        [--csv benchmarks/sps_nial/step_halving.csv]
"""
import argparse
import json
import os
import subprocess

from benchmarks.perf.harness import write_csv_atomic
from tools import sps_outputs as so

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


QS_LIMITS = ("max_strain_increment", "max_approach_increment", "max_mean_strain_increment")


def load(config):
    path = os.path.join(REPO, config)
    with open(path) as f:
        c = json.load(f)
    so.absolute_includes(c, os.path.dirname(path))
    return c


def scene(config, seed, factor, hot_press=None, size=1.0):
    c = load(config)
    c["seed"] = seed
    gen = c["stages"][0].get("generator", {})
    for k in ("radius", "length"):  # size x the particles: the die and the compact scaled by size^(1/3)
        if k in gen:
            gen[k] *= size ** (1.0 / 3.0)
    c["stages"] = [st for st in c["stages"] if st["name"] != "cooled_conductivity"]
    if hot_press:
        hp = next(st for st in load(hot_press)["stages"] if st["name"] == "hot_press")
        c["stages"] = [hp if st["name"] == "hot_press" else st for st in c["stages"]]
    for st in c["stages"]:
        if st["name"] not in ("heat", "hot_press"):
            continue
        if "quasi_static" in st:
            st["dt"] *= factor
            for k in QS_LIMITS:
                if k in st["quasi_static"]:
                    st["quasi_static"][k] *= factor
        else:
            st["dt_fraction"] *= factor
        if "timeseries_every" in st.get("output", {}):
            st["output"]["timeseries_every"] = int(st["output"]["timeseries_every"] / factor)
    return c


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--config", default="configs/sps_nial_small.json")
    ap.add_argument("--hot-press", default=None, help="a config whose hot_press stage replaces the config's")
    ap.add_argument("--size", type=float, default=1.0, help="the compact's volume (and particle count) x this")
    ap.add_argument("--factors", default="1,0.5", help="step factors to run, the first the reference (\"1\": the gates of one run)")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--csv", default=os.path.join(REPO, "benchmarks/sps_nial/step_halving.csv"))
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    version = subprocess.run([a.sparkdem, "--version"], capture_output=True, text=True).stdout.strip()
    runs, particles = {}, {}
    factors = [float(x) for x in a.factors.split(",")]
    for factor in factors:
        name = f"dt_x{factor:g}"
        path, out = os.path.join(a.workdir, name + ".json"), os.path.join(a.workdir, name + "_out")
        with open(path, "w") as f:
            json.dump(scene(a.config, a.seed, factor, a.hot_press, a.size), f, indent=1)
        subprocess.run([a.sparkdem, "run", path, "-o", out, "--threads", "1", "--quiet"], check=False)
        with open(os.path.join(out, "summary.json")) as f:
            s = json.load(f)
        particles[factor] = so.find_stage(s, "hot_press").get("particles")
        runs[factor] = (so.find_stage(s, "hot_press").get("snapshots", {}).get("taken", []), so.sweep_values(s, "conductivity_no_gb"),
                        so.sweep_values(s, "conductivity_gb"))
    rows = []
    for factor, (taken, nogb, gb) in runs.items():
        for t in taken:
            k = t["index"]
            g = so.quasi_static_gates(t.get("columns", {}))
            ref = runs[factors[0]]
            row = {"seed": a.seed, "size": a.size, "particles": particles[factor], "dt_factor": factor, "snapshot": k, "target": t.get("target"), "porosity_taken": t["value"],
                   "kappa_without_layer": nogb.get(k), "kappa_with_layer": gb.get(k), "binary": version}
            if factor != factors[0] and nogb.get(k) and ref[1].get(k):
                row["kappa_without_layer_change"] = nogb[k] / ref[1][k] - 1.0
            if factor != factors[0] and gb.get(k) and ref[2].get(k):
                row["kappa_with_layer_change"] = gb[k] / ref[2][k] - 1.0
            row.update({f"qs_{n}": g.get(n) for n in so.QUANTITIES})
            rows.append(row)
    fields = ["seed", "size", "particles", "dt_factor", "snapshot", "target", "porosity_taken", "kappa_without_layer", "kappa_with_layer", "kappa_without_layer_change",
              "kappa_with_layer_change"] + [f"qs_{n}" for n in so.QUANTITIES] + ["binary"]
    write_csv_atomic(a.csv, [{k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()} for r in rows], fields)
    print(open(a.csv).read())


if __name__ == "__main__":
    main()
