#!/usr/bin/env python3
"""Issue 21, item 2: the network models of a sintered sample against the continuum of its own
geometry and the Hashin-Shtrikman bound, on the four snapshots of one main-scenario run.

For every snapshot hot_press_K.h5 of RUN/snapshots/:
  - sparkdem on the snapshot (a zero-step stage from_snapshot, the scenario's electrodes and neck
    model: constant-volume necks, FE hemisphere table, grain-boundary-fraction correction), no
    grain-boundary layer: the paper's particle-centred network and the sphere-element network
    (physics/electrical/sphere_element.hpp); L = the electrode centroid distance (the scenario's);
  - tools/voxel_conductivity.py on the same spheres: the whole sample in the die (voxel 0.8 um)
    and a 40 um cube at its centre (0.4 um), the union of the spheres as they are;
  - the porosities: by mass (the scenario's porosity_mass), of the union, and both in the core cube;
    the Hashin-Shtrikman upper bound kappa_b 2 (1 - p) / (2 + p) at the mass and union porosities.
Then the grain-boundary layer of each network calibrated on snapshot 1 (target 6.14 MS/m, secant
on log delta_gb, eps = 0.16) and applied to the other three.

Writes OUT/networks.csv (one row per snapshot) and OUT/networks_layer.csv (the calibration).
Usage: networks.py RUN_DIR OUT_DIR [--sparkdem build/sparkdem] [--skip-voxel]
       networks.py --summary OUT.csv DIR [DIR ...]   (mean and std over runs of every column)
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
KAPPA_B = 9.8e6
TARGET = 6.14e6  # seed 000 Table 1, porosity 0.164 (the paper's calibration sample)
MEASURED = {0: (0.216, 4.33e6), 1: (0.164, 6.14e6), 2: (0.106, 7.44e6), 3: (0.050, 8.77e6)}


def hs(p):
    return 2.0 * (1.0 - p) / (2.0 + p)


def network_stage(snapshot, topology, gb_thickness):
    return {"name": f"{topology}_{os.path.basename(snapshot).split('.')[0]}", "type": "dynamics",
            "sets": ["top_electrode", "bottom_electrode"], "from_snapshot": snapshot, "dt_fraction": 0.1, "stop": {"steps": 0},
            "modules": {"electrical_network": {
                "model": "sintered_neck", "neck": "cv", "hemisphere": "fe_table", "gbf_correction": True, "conductivity": KAPPA_B,
                "gb_thickness": gb_thickness, "gb_epsilon": 0.16, "high": "top_electrode", "low": "bottom_electrode",
                "voltage": 0.001, "solver": "cg_ic", "topology": topology}}}


def run_stages(sparkdem, stages, work):
    """Runs the stages in one scene; returns {stage name: (kappa_eff, negative_share, solve_s)}."""
    scene = json.load(open(os.path.join(ROOT, "configs", "sps_nial.json")))
    scene["name"] = "networks"
    scene["stages"] = stages
    os.makedirs(work, exist_ok=True)
    path = os.path.join(work, "scene.json")
    json.dump(scene, open(path, "w"), indent=1)
    out = os.path.join(work, "out")
    subprocess.run([sparkdem, "run", path, "-o", out, "--threads", "2", "--quiet"], check=True)
    names = [s["name"] for s in stages]
    res = {}
    for row in csv.DictReader(open(os.path.join(out, "timeseries.csv"))):
        name = names[int(row["stage"])]
        res[name] = (float(row["electrical_conductivity_eff"]), float(row.get("electrical_negative_share") or "nan"),
                     float(row["electrical_solve_time"]))
    return res


def voxel(snapshot, box, h):
    out = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "voxel_conductivity.py"), snapshot, "--voxel", str(h), "--box", box],
                         check=True, capture_output=True, text=True).stdout
    return {k: v for k, v in (x.split("=", 1) for x in out.split())}


def calibrate_thickness(kappa_of, target):
    """delta_gb [m] with kappa_of(delta_gb) = target [S/m]: secant on log(delta) from 0.1 and 1 um,
    to 1e-4 of the target (at most 30 steps). Returns (delta_gb, kappa there). Shared with the
    ledger's NiAl case (benchmarks/validation/cases.py)."""
    f = lambda x: kappa_of(math.exp(x)) - target
    x0, x1 = math.log(1e-7), math.log(1e-6)
    f0, f1 = f(x0), f(x1)
    for _ in range(30):
        if abs(f1) < 1e-4 * target or f1 == f0:
            break
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = f(x1)
    return math.exp(x1), f1 + target


def calibrate(sparkdem, snapshot, topology, work):
    """delta_gb [m] with kappa(snapshot) = TARGET (calibrate_thickness)."""
    def kappa_of(d):
        st = network_stage(snapshot, topology, d)
        return run_stages(sparkdem, [st], work)[st["name"]][0]
    return calibrate_thickness(kappa_of, TARGET)


def summarize(out, dirs):
    """Mean and sample std over the runs in `dirs` of every numeric column, per snapshot (networks.csv)
    and per topology and snapshot (networks_layer.csv)."""
    import statistics as st
    rows = []
    for name, keys in (("networks.csv", ("snapshot",)), ("networks_layer.csv", ("topology", "snapshot"))):
        groups = {}
        for d in dirs:
            for r in csv.DictReader(open(os.path.join(d, name))):
                groups.setdefault(tuple(r[k] for k in keys), []).append(r)
        for key, rs in groups.items():
            for col in rs[0]:
                if col in keys or col == "role":
                    continue
                try:
                    v = [float(r[col]) for r in rs]
                except ValueError:
                    continue
                rows.append({"table": name, "group": "/".join(key), "column": col, "runs": len(v), "mean": st.mean(v),
                             "std": st.stdev(v) if len(v) > 1 else 0.0})
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def main():
    if len(sys.argv) > 2 and sys.argv[1] == "--summary":
        return summarize(sys.argv[2], sys.argv[3:])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run")
    ap.add_argument("out")
    ap.add_argument("--sparkdem", default=os.path.join(ROOT, "build", "sparkdem"))
    ap.add_argument("--skip-voxel", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    snaps = [os.path.join(os.path.abspath(a.run), "snapshots", f"hot_press_{k}.h5") for k in range(4)]
    work = os.path.join(a.out, "work")
    t0 = time.time()
    stages = [network_stage(s, t, 0.0) for s in snaps for t in ("particle_centred", "sphere_element")]
    net = run_stages(a.sparkdem, stages, work)
    t_net = time.time() - t0
    summary = json.load(open(os.path.join(a.run, "summary.json")))
    rows = []
    for k, s in enumerate(snaps):
        pc = net[network_stage(s, "particle_centred", 0.0)["name"]]
        se = net[network_stage(s, "sphere_element", 0.0)["name"]]
        row = {"snapshot": k, "porosity_measured": MEASURED[k][0], "kappa_measured": MEASURED[k][1],
               "kappa_particle_centred": pc[0], "kappa_sphere_element": se[0], "negative_share": se[1], "solve_s_particle_centred": pc[2],
               "solve_s_sphere_element": se[2]}
        if not a.skip_voxel:
            w = voxel(s, "whole", 0.8e-6)
            c = voxel(s, "centre:40e-6", 0.4e-6)
            pm, pu = float(w["porosity_mass"]), float(w["porosity_voxel"])
            row.update({"porosity_mass": pm, "porosity_union": pu, "core_porosity_mass": float(c["porosity_mass"]),
                        "core_porosity_union": float(c["porosity_voxel"]), "hs_mass": KAPPA_B * hs(pm), "hs_union": KAPPA_B * hs(pu),
                        "kappa_voxel_union": KAPPA_B * float(w["kappa_rel"]), "kappa_voxel_core": KAPPA_B * float(c["kappa_rel"]),
                        "voxel_solve_s": float(w["solve_s"])})
            for m in ("particle_centred", "sphere_element"):
                row[f"{m}_over_hs_mass"] = row[f"kappa_{m}"] / row["hs_mass"]
                row[f"{m}_over_hs_union"] = row[f"kappa_{m}"] / row["hs_union"]
                row[f"{m}_over_voxel"] = row[f"kappa_{m}"] / row["kappa_voxel_union"]
        rows.append(row)
        print(row, flush=True)
    with open(os.path.join(a.out, "networks.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    # The layer calibrated on snapshot 1, applied to all four.
    lrows = []
    for topo in ("particle_centred", "sphere_element"):
        t1 = time.time()
        d, k1 = calibrate(a.sparkdem, snaps[1], topo, os.path.join(work, "cal_" + topo))
        res = run_stages(a.sparkdem, [network_stage(s, topo, d) for s in snaps], os.path.join(work, "val_" + topo))
        for k, s in enumerate(snaps):
            kap = res[network_stage(s, topo, d)["name"]][0]
            lrows.append({"topology": topo, "delta_gb_m": d, "eps_over_delta_per_um": 0.16 / (d * 1e6), "snapshot": k,
                          "porosity_measured": MEASURED[k][0], "kappa": kap, "kappa_measured": MEASURED[k][1],
                          "error": kap / MEASURED[k][1] - 1.0, "role": "calibrated" if k == 1 else "validation", "seconds": time.time() - t1})
            print(lrows[-1], flush=True)
    with open(os.path.join(a.out, "networks_layer.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(lrows[0]))
        w.writeheader()
        w.writerows(lrows)
    print(f"networks: {t_net:.1f} s for the eight network solves; total {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
