#!/usr/bin/python3
"""Tabulate the sintering-parameter sensitivity runs (benchmarks/sps_sensitivity/run_sensitivity.sh).

Each run directory holds variant.txt ("baseline" or PARAMETER=VALUE), scene.json, out/ and time.txt.
Per variant and snapshot target porosity (--targets) one CSV row: the porosity taken, the
physical time since the pipeline's start (time_s; the hot press starts at 480 s) and the
temperature when the snapshot was taken (timeseries.csv at the snapshot's step), the necks' mean
a / r_min, kappa_eff with the grain-boundary layer (the baseline's calibrated thickness, fixed)
and without it, the relative changes against the baseline in % (the time's shift in s: the
densification speed), and the run's wall time. A target the run did not reach is a row "not reached". At the end, the largest |change| per parameter.
Needs h5py (Debian python3-h5py); the readers are in tools/sps_outputs.py.
"""
import argparse, csv, json, math, os, sys
import numpy as np

from tools.sps_outputs import find_stage, snapshots, sweep_values, timeseries

# (quantity, change column): relative change in %, except the time's shift in s
QUANTITIES = [("mean_a_over_rmin", "d_mean_a_pct"), ("kappa_gb", "d_kappa_gb_pct"), ("kappa_no_gb", "d_kappa_no_gb_pct"),
              ("time_s", "d_time_s")]


def load(run):
    variant = open(os.path.join(run, "variant.txt")).read().strip()
    out = os.path.join(run, "out")
    times = open(os.path.join(run, "time.txt")).read().splitlines()[-1].split() if os.path.exists(os.path.join(run, "time.txt")) else []
    d = {"variant": variant, "wall_s": float(times[0]) if times else float("nan"), "snaps": {}}
    if not os.path.exists(os.path.join(out, "summary.json")):
        return d
    summary = json.load(open(os.path.join(out, "summary.json")))
    ts = timeseries(out)
    press = ts["stage"] == next(k for k, s in enumerate(summary["stages"]) if s["name"] == "hot_press")
    gb, no_gb = sweep_values(summary, "conductivity_gb"), sweep_values(summary, "conductivity_no_gb")
    for s in snapshots(out, find_stage(summary, "hot_press")):
        d["snaps"][s["target"]] = {"porosity": s["value"],
                                   "time_s": float(np.interp(s["step"], ts["step"][press], ts["physical_time"][press])),
                                   "temperature_K": float(np.interp(s["step"], ts["step"][press], ts["temperature"][press])),
                                   "necks": s["necks"], "mean_a_over_rmin": s["mean_a_over_rmin"],
                                   "kappa_gb": gb.get(s["index"], float("nan")),
                                   "kappa_no_gb": no_gb.get(s["index"], float("nan"))}
    return d


def change(q, v, r):
    if q == "time_s":
        return v - r
    return 100.0 * (v / r - 1.0) if r and math.isfinite(v) and math.isfinite(r) else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("--targets", default="0.216,0.164,0.106,0.05")
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args()
    targets = [float(x) for x in a.targets.split(",")]
    res = [load(r) for r in a.runs]
    ref = next(d for d in res if d["variant"] == "baseline")
    worst = {}  # parameter -> {change column: (|change|, variant, target)}
    with open(a.csv, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["variant", "parameter", "value", "target_porosity", "porosity", "time_s", "temperature_K", "necks",
                    "mean_a_over_rmin", "kappa_gb_S_per_m", "kappa_no_gb_S_per_m"] + [c for _, c in QUANTITIES] + ["run_wall_s"])
        for d in res:
            param, _, value = d["variant"].partition("=")
            for tgt in targets:
                s, r = d["snaps"].get(tgt), ref["snaps"].get(tgt)
                head = [d["variant"], param, value, tgt]
                if s is None:
                    w.writerow(head + ["not reached"] + [""] * (6 + len(QUANTITIES)) + [d["wall_s"]])
                    continue
                ch = [change(q, s[q], r[q]) if r else float("nan") for q, _ in QUANTITIES]
                w.writerow(head + ["%.4f" % s["porosity"], "%.1f" % s["time_s"], "%.1f" % s["temperature_K"], s["necks"],
                                   "%.4f" % s["mean_a_over_rmin"], "%.4g" % s["kappa_gb"], "%.4g" % s["kappa_no_gb"]]
                           + ["%.2f" % c for c in ch] + [d["wall_s"]])
                if param != "baseline":
                    for (_, col), c in zip(QUANTITIES, ch):
                        if math.isfinite(c) and abs(c) > worst.setdefault(param, {}).get(col, (-1,))[0]:
                            worst[param][col] = (abs(c), c, d["variant"], tgt)
    print(open(a.csv).read())
    print("largest |change| against the baseline per parameter (over its values and the snapshots reached):")
    for param, cols in worst.items():
        print("  %-26s" % param + "  ".join("%s %+7.2f%s (%s, phi %g)" % (col[2:].rsplit("_", 1)[0], c[1], " s" if col == "d_time_s" else " %", c[2].partition("=")[2], c[3])
                                              for col, c in ((col, cols[col]) for _, col in QUANTITIES if col in cols)))
    missing = [(d["variant"], t) for d in res for t in targets if t not in d["snaps"]]
    if missing:
        print("not reached: " + ", ".join("%s at %g" % m for m in missing))


if __name__ == "__main__":
    sys.exit(main())
