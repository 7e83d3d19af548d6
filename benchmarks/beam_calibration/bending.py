#!/usr/bin/env python3
"""Pure-bending strength calibration of the cohesive beams (issue 20 step 3).

usage: benchmarks/beam_calibration/bending.py [--sizes "5000"] [--seeds "1"] [--workdir DIR]
           [--sparkdem PATH] [--csv FILE] [--write]

Runs configs/calibration/cast_iron_bending.json (the pin's geometry and packing, both end layers
turned in opposite senses about x: uniform bending moment, elastic) at each N and packing seed,
with only the element count changed and the end-layer thickness and rotation centres scaled with
the element size (r ~ N^(-1/3), as benchmarks/torsion_crack/run_torsion.py). Per run, from the
time series of the bend stage over the rows past a quarter of the final rotation (the start
transient excluded):
  sigma      = 4 M / (pi r^3), M the moment on the lower end layer (torsion_test, axis x):
               the surface fibre stress of beam theory
  criterion  = bonds_max_failure_stress (the largest von Mises beam stress of any bond)
  ratio      = slope(criterion vs rotation) / slope(sigma vs rotation) (least squares through 0)
  stiffness  = slope(sigma) / (E r / L_c) per unit relative rotation, the bending stiffness
               against beam theory (E = 124 GPa, L_c the distance of the rotation centres)
  strength   = sigma_t x ratio, sigma_t = sqrt(3) x 400 MPa = 692.8 MPa: the beam strength at
               which the first bond breaks when the surface fibre reaches sigma_t
--write sets `strength` of configs/materials/cast_iron_beams.json to the first run's value and
writes configs/materials/cast_iron_beams.bending.json (the runs, the fit, the command).
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = os.path.join(REPO, "configs", "calibration", "cast_iron_bending.json")
SIGMA_T = math.sqrt(3.0) * 400e6  # [Pa]
E_TARGET = 124e9                  # [Pa]
RADIUS = 1e-3                     # [m]


def scene_for(n, seed):
    j = json.load(open(SCENE))
    n0 = j["stages"][0]["generator"]["particles"]
    length = j["stages"][0]["generator"]["length"]
    scale = (n0 / n) ** (1.0 / 3.0)
    j["stages"][0]["generator"]["particles"] = n
    j["seed"] = seed
    j["bonds"]["params"]["$include"] = os.path.join(REPO, "configs", "materials", "cast_iron_beams.json")
    for s in j["particle_sets"].values():
        s["thickness"] *= scale
    bend = j["stages"][1]
    z_low = bend["prescribe"]["lower"]["center"][2] * scale
    bend["prescribe"]["lower"]["center"][2] = z_low
    bend["prescribe"]["upper"]["center"][2] = length - z_low
    bend["modules"]["torsion_test"]["axis_point"][2] = z_low
    return j, length - 2.0 * z_low


def slope(x, y):
    return sum(a * b for a, b in zip(x, y)) / sum(a * a for a in x)


def analyse(out, centre_distance):
    rows = [r for r in csv.DictReader(open(os.path.join(out, "timeseries.csv"))) if r["stage"] == "1"]
    phi = [2.0 * float(r["torsion_twist"]) for r in rows]  # relative rotation of the two ends
    keep = [k for k, p in enumerate(phi) if p >= 0.25 * phi[-1]]
    x = [phi[k] for k in keep]
    sigma = [2.0 * float(rows[k]["torsion_shear_stress"]) for k in keep]  # 4 M / (pi r^3)
    crit = [float(rows[k]["bonds_max_failure_stress"]) for k in keep]
    s_sigma, s_crit = slope(x, sigma), slope(x, crit)
    return {"rows_fitted": len(keep), "final_rotation_rad": phi[-1], "ratio": s_crit / s_sigma,
            "stiffness": s_sigma / (E_TARGET * RADIUS / centre_distance),
            "strength_Pa": SIGMA_T * s_crit / s_sigma,
            "max_ke_over_elastic": max(float(rows[k]["kinetic_energy"]) / float(rows[k]["bonds_elastic_energy"]) for k in keep),
            "broken": float(rows[-1]["bonds_broken"])}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="5000")
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--workdir", default="/tmp/sparkdem_bending")
    ap.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    ap.add_argument("--csv", default="")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args()
    results = []
    for n in [int(x) for x in a.sizes.split()]:
        for seed in [int(x) for x in a.seeds.split()]:
            d = os.path.join(a.workdir, "N%d_seed%d" % (n, seed))
            os.makedirs(d, exist_ok=True)
            scene, lc = scene_for(n, seed)
            json.dump(scene, open(os.path.join(d, "scenario.json"), "w"), indent=1)
            t0 = time.time()
            subprocess.check_call([a.sparkdem, "run", os.path.join(d, "scenario.json"), "-o", os.path.join(d, "out"),
                                   "--threads", "1", "--quiet"], env=dict(os.environ, OMP_WAIT_POLICY="PASSIVE"))
            r = dict(N=n, seed=seed, centre_distance_m=lc, wall_s=round(time.time() - t0, 1), **analyse(os.path.join(d, "out"), lc))
            results.append(r)
            print("N=%d seed=%d: criterion/sigma %.3f, strength %.4g Pa, bending stiffness %.4f, max KE/elastic %.3g, %d broken, %.0f s"
                  % (n, seed, r["ratio"], r["strength_Pa"], r["stiffness"], r["max_ke_over_elastic"], r["broken"], r["wall_s"]))
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(results[0].keys()))
            w.writeheader()
            w.writerows(results)
    if a.write:
        p = os.path.join(REPO, "configs", "materials", "cast_iron_beams.json")
        params = json.load(open(p))
        params["strength"] = results[0]["strength_Pa"]
        json.dump(params, open(p, "w"), indent=2)
        open(p, "a").write("\n")
        report = {"command": "benchmarks/beam_calibration/bending.py " + " ".join(sys.argv[1:]),
                  "scene": "configs/calibration/cast_iron_bending.json", "sigma_t_Pa": SIGMA_T,
                  "strength_Pa": results[0]["strength_Pa"], "runs": results}
        json.dump(report, open(os.path.join(REPO, "configs", "materials", "cast_iron_beams.bending.json"), "w"), indent=1)
        print("strength %.6g Pa written to %s" % (results[0]["strength_Pa"], p))


if __name__ == "__main__":
    main()
