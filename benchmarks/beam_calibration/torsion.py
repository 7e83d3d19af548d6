#!/usr/bin/python3
"""Beam calibration in torsion on the pin, as seed 001 §4 did it (issue 38 item 3).

The seed fitted its beams "in order to obtain a macroscopic behaviour consistent with the
theoretical torsion solution" on the 5000-element pin. This script does that on calibration
packing seeds (101, 102, 103 by default) that the ledger never uses for validation (seed001/torsion
runs seeds 1-5):

  scene      configs/torsion_crack.json at N (run_torsion.scene_for: the end sets and gap follow
             the element size), its packing protocol included (relax to the interior solid
             fraction, issue 38 item 1), the beams of its $include, strength 1e30 (nothing
             breaks), no electrical network (the fit reads mechanics only), twisted to
             `--twist` rad (default 0.03, below the predicted onset 0.0416) at the config's rate
  k          slope(torque) / slope(G J theta / L) over the rows past a quarter of the final twist
             (least squares through 0; the start transient excluded), mean over the seeds
  s_crit     slope(bonds_max_failure_stress) [Pa/rad] over the same rows: the largest von Mises
             beam stress per unit twist, mean over the seeds

Model choice fixed before any torsion run: the beam radius ratio stays the tension calibration's
(configs/materials/cast_iron_beams.calibration.json: nu_M = 0.29); one slope fixes one parameter,
and the radius ratio sets the ratio of bending to stretching stiffness that tension measures as
nu_M. A beam lattice is linear in E_mu before the first break, so each iteration sets
E_mu <- E_mu / k and the criterion slope with it (s_crit / k); iterations stop when |k - 1| <
--tolerance (default 0.002; the last iteration's k is the calibration's residual). The strength is
the first-break twist's: the first bond breaks where the criterion reaches the strength, so
strength = s_crit x theta_y, theta_y = tau_y L / (G r) = 0.0416 rad, from the last iteration.

--write writes the beams file the config's bonds $include (configs/torsion_crack.json:
configs/materials/cast_iron_beams_torsion.json; configs/torsion_contact.json, the paper's contact
definition of issue 58: cast_iron_beams_torsion_contact.json) and its .calibration.json beside it
(every run, the fit, the command).

    python3 -m benchmarks.beam_calibration.torsion --sparkdem BIN --workdir DIR [--n 5000]
        [--seeds 101,102,103] [--twist 0.03] [--config configs/torsion_crack.json] [--reuse] [--write]
"""
import concurrent.futures
import csv
import json
import os
import statistics
import sys

from benchmarks.beam_calibration.bending import slope
from benchmarks.perf.harness import run_study_scene, study_parser, write_json_atomic
from benchmarks.torsion_crack import run_torsion as rt

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIG = os.path.join(REPO, "configs", "torsion_crack.json")
TENSION = os.path.join(REPO, "configs", "materials", "cast_iron_beams.json")
THETA_Y = rt.PREDICTED_ONSET  # tau_y L / (G r) [rad]


def beams_file(config):
    """The beams file the config's bonds include (the file --write rewrites)."""
    with open(config) as f:
        inc = json.load(f)["bonds"]["params"]["$include"]
    return os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(config)), inc))


def scene(config, n, seed, beams, twist):
    j = rt.scene_for(config, n, seed)
    j["bonds"]["params"] = dict(beams, strength=1e30)
    st = j["stages"][1]
    st["modules"].pop("electrical_network")
    st["modules"]["torsion_test"].pop("report_twists", None)
    st["modules"]["torsion_test"]["resistance_signal"] = ""
    st["stop"] = {"time": twist / st["prescribe"]["twisted"]["angular_velocity"][2]}
    st["output"] = {"timeseries_every": 50}
    j["checks"] = []
    return j


def fit(out):
    with open(os.path.join(out, "timeseries.csv"), newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["stage"] == "1"]
    th = [float(r["torsion_twist"]) for r in rows]
    keep = [k for k, t in enumerate(th) if t >= 0.25 * th[-1]]
    x = [th[k] for k in keep]
    col = lambda name: [float(rows[k][name]) for k in keep]
    return {"rows_fitted": len(keep), "final_twist_rad": th[-1],
            "k": slope(x, col("torsion_torque")) / slope(x, col("torsion_elastic_torque")),
            "s_crit_Pa_per_rad": slope(x, col("bonds_max_failure_stress")),
            "max_ke_over_elastic": max(a / b for a, b in zip(col("kinetic_energy"), col("bonds_elastic_energy"))),
            "broken": float(rows[-1]["bonds_broken"])}


def run_one(a, it, beams, n, seed):
    out, s = run_study_scene(os.path.abspath(a.sparkdem), a.workdir, f"it{it}_N{n}_s{seed}", scene(a.config, n, seed, beams, a.twist),
                             reuse=a.reuse)
    pk = next(x for x in s["stages"] if x["name"] == "pack")["packing"]
    return dict(iteration=it, N=n, seed=seed, young_modulus_Pa=beams["young_modulus"], **fit(out),
                packing_density=pk["packing_density"], density_profile_interior=pk["density_profile_interior"],
                wall_time_s=s["wall_time_s"])


def main():
    ap = study_parser(__doc__, "5000", "", seeds_default="101,102,103")
    ap.add_argument("--twist", type=float, default=0.03)
    ap.add_argument("--config", default=CONFIG, help="the pin's scenario (its bonds $include is the beams file)")
    ap.add_argument("--tolerance", type=float, default=0.002)
    ap.add_argument("--max-iterations", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--reuse", action="store_true", help="keep finished runs of an identical scenario")
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    with open(TENSION) as f:
        beams = {k: v for k, v in json.load(f).items() if k != "strength"}
    jobs = [(int(n), int(s)) for n in a.n.split(",") for s in a.seeds.split(",")]
    runs = []
    for it in range(a.max_iterations):
        with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
            rows = list(ex.map(lambda j: run_one(a, it, beams, *j), jobs))
        runs += rows
        k = statistics.mean(r["k"] for r in rows)
        s_crit = statistics.mean(r["s_crit_Pa_per_rad"] for r in rows)
        print(f"iteration {it}: E_mu {beams['young_modulus']:.6g} Pa, k {k:.5f} +- {statistics.stdev(r['k'] for r in rows):.5f}, "
              f"criterion slope {s_crit:.6g} Pa/rad", flush=True)
        if abs(k - 1.0) < a.tolerance:
            break
        beams["young_modulus"] /= k
    beams["strength"] = s_crit * THETA_Y
    print(f"E_mu {beams['young_modulus']:.6g} Pa, radius_ratio {beams['radius_ratio']:.6g}, strength {beams['strength']:.6g} Pa "
          f"(residual k - 1 = {k - 1.0:+.5f})")
    if a.write:
        out = beams_file(a.config)
        write_json_atomic(out, beams)
        write_json_atomic(out.replace(".json", ".calibration.json"), {
            "command": "python3 -m benchmarks.beam_calibration.torsion " + " ".join(sys.argv[1:]),
            "scene": f"{os.path.relpath(a.config, REPO)} (strength 1e30, no electrical network, twist {a.twist} rad)",
            "theta_y_rad": THETA_Y, "residual_k_minus_1": k - 1.0, "criterion_slope_Pa_per_rad": s_crit,
            "params": beams, "runs": runs})

if __name__ == "__main__":
    main()
