#!/usr/bin/python3
"""Compare hot-press runs made at different time scalings (benchmarks/sps_scaling/run_scaling.sh).

For each run directory (scene.json, out/, time.txt) it reports:
  - the time scale, the hot press's steps and wall time, the whole run's wall and CPU time;
  - porosity_mass at fixed temperatures of the heating ramp (first crossing of each T);
  - each snapshot: target, porosity taken, mean and histogram (10 bins on [0, 1]) of a / r_min
    over the sintered necks (neck_radius > 0, from the snapshot's contact state);
  - the conductivity of each snapshot with and without the grain-boundary layer;
  - max kinetic energy / punch work (wall 'top') during the hot press, the work counted as the total mechanical work
    exchanged through the punch, W(t) = integral |F du| (the compact also pushes the punch back
    when it expands), after W has reached 1 % of its final value.
Differences are given against the run with the smallest time scale (the slowest, reference).
Needs h5py (Debian python3-h5py); the snapshot and sweep readers are in tools/sps_outputs.py.
"""
import argparse, csv, json, os, sys
import numpy as np

from tools.sps_outputs import find_stage, snapshots, sweep_values

T_GRID = [1100.0, 1200.0, 1300.0, 1400.0, 1500.0, 1573.0]


def load(run):
    out = os.path.join(run, "out")
    scene = json.load(open(os.path.join(run, "scene.json")))
    press = next(s for s in scene["stages"] if s["name"] == "hot_press")
    summary = json.load(open(os.path.join(out, "summary.json")))
    st = find_stage(summary, "hot_press")
    rows = [r for r in csv.DictReader(open(os.path.join(out, "timeseries.csv")))
            if "temperature" in r and r["temperature"] not in ("", "nan")]
    T = np.array([float(r["temperature"]) for r in rows])
    phi = np.array([float(r["porosity_mass"]) for r in rows])
    ke = np.array([float(r["kinetic_energy"]) for r in rows])
    F = np.array([float(r["wall_top_normal_force"]) for r in rows])
    u = np.array([float(r["wall_top_offset"]) for r in rows])
    work = np.concatenate([[0.0], np.cumsum(np.abs(0.5 * (F[1:] + F[:-1]) * np.diff(u)))])
    # The ratio over the hot press only (the stage whose time scale the study changes); the work
    # is counted from the start of the run (the cold pressing before it included).
    press_index = str([s["name"] for s in summary["stages"]].index("hot_press"))
    in_press = np.array([r.get("stage") == press_index for r in rows])
    on = (work > 0.01 * work[-1]) & in_press
    ratio = float(np.max(ke[on] / work[on])) if on.any() and work[-1] > 0 else float("nan")
    phi_at_T = {}
    for t in T_GRID:
        k = np.argmax(T >= t - 1e-9)
        phi_at_T[t] = float(phi[k]) if T[k] >= t - 1e-9 else float("nan")
    snaps = snapshots(out, st)
    kappa = {(name, k): v for name in ("conductivity_gb", "conductivity_no_gb")
             for k, v in sweep_values(summary, name).items()}
    wall, user, sys_ = (float(v) for v in open(os.path.join(run, "time.txt")).read().splitlines()[-1].split()[:3])
    return {"run": run, "time_scale": press["time_scale"], "press_steps": st["steps"],
            "press_wall_s": st["wall_time_s"], "run_wall_s": wall, "run_cpu_s": user + sys_,
            "phi_at_T": phi_at_T, "snaps": snaps, "kappa": kappa, "ke_over_work_max": ratio}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args()
    res = sorted((load(r) for r in a.runs), key=lambda d: d["time_scale"])
    ref = res[0]
    with open(a.csv, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_scale", "press_steps", "press_wall_s", "run_wall_s", "run_cpu_s", "ke_over_work_max", "quantity",
                    "value", "reference_value", "difference"])
        for d in res:
            base = [d["time_scale"], d["press_steps"], round(d["press_wall_s"], 2), d["run_wall_s"], round(d["run_cpu_s"], 2),
                    "%.3g" % d["ke_over_work_max"]]
            for t in T_GRID:
                v, r = d["phi_at_T"][t], ref["phi_at_T"][t]
                w.writerow(base + ["porosity_mass at %g K" % t, "%.5f" % v, "%.5f" % r, "%.5f" % (v - r)])
            for k, s in enumerate(d["snaps"]):
                rs = ref["snaps"][k] if k < len(ref["snaps"]) else None
                w.writerow(base + ["snapshot %g: porosity" % s["target"], "%.5f" % s["value"],
                                   "%.5f" % rs["value"] if rs else "", "%.5f" % (s["value"] - rs["value"]) if rs else ""])
                w.writerow(base + ["snapshot %g: mean a/r_min (%d necks)" % (s["target"], s["necks"]),
                                   "%.4f" % s["mean_a_over_rmin"], "%.4f" % rs["mean_a_over_rmin"] if rs else "",
                                   "%.4f" % (s["mean_a_over_rmin"] - rs["mean_a_over_rmin"]) if rs else ""])
                if rs:
                    l1 = float(np.abs(np.array(s["hist"]) - np.array(rs["hist"])).sum())
                    w.writerow(base + ["snapshot %g: neck histogram L1 distance" % s["target"], "%.4f" % l1, "0", "%.4f" % l1])
                for name in ("conductivity_gb", "conductivity_no_gb"):
                    v = d["kappa"].get((name, k))
                    r = ref["kappa"].get((name, k))
                    if v is not None:
                        w.writerow(base + ["snapshot %g: %s [S/m]" % (s["target"], name), "%.4g" % v,
                                           "%.4g" % r if r else "", "%.3f %%" % (100 * (v / r - 1)) if r else ""])
    print(open(a.csv).read())


if __name__ == "__main__":
    sys.exit(main())
