#!/usr/bin/env python3
"""Pin torsion plots (seed 001 Fig. 16) from a run of configs/torsion_contact.json or torsion_crack.json.

usage: tools/plot_torsion.py RUN_DIR [-o OUT_DIR] [--stage NAME]

Reads RUN_DIR/timeseries.csv (columns of the torsion_test module and the built-in bond columns)
and RUN_DIR/broken_bonds.csv, and writes to OUT_DIR (default RUN_DIR):
  torsion.png        torque and the elastic line G J theta / L against twist (left axis), R/R0
                     (right axis, log) and the broken-bond count (bottom panel), the onsets marked
  torsion_table.csv  the data of torsion.png, per time-series row: twist, torque, elastic torque,
                     tau_max/tau_y, R/R0, broken bonds, kinetic/elastic energy ratio
  torsion_onsets.csv the onset twists marked in torsion.png (first break, R rise, R off its trend, separation)
  torsion_breaks.png the broken bonds' midpoints (z against angle around the axis), coloured by
                     the twist at which they broke
  torsion_breaks.csv its data: per broken bond, angle [rad], z [m], twist at break [rad]
Only the Python standard library and matplotlib (python3-matplotlib) are needed.
"""
import argparse
import csv
import math
import os
import sys


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("-o", "--out", default=None)
    ap.add_argument("--stage", default=None, help="only rows of this stage index (default: every row with a twist)")
    a = ap.parse_args()
    out = a.out or a.run_dir
    os.makedirs(out, exist_ok=True)
    rows = [r for r in read_csv(os.path.join(a.run_dir, "timeseries.csv")) if not math.isnan(num(r.get("torsion_twist")))]
    if a.stage is not None:
        rows = [r for r in rows if r["stage"] == a.stage]
    if not rows:
        sys.exit("no torsion_test rows in %s/timeseries.csv" % a.run_dir)
    tw = [num(r["torsion_twist"]) for r in rows]
    T = [num(r["torsion_torque"]) for r in rows]
    Tel = [num(r["torsion_elastic_torque"]) for r in rows]
    ratio = [num(r["torsion_resistance_ratio"]) for r in rows]
    broken = [num(r.get("bonds_broken")) for r in rows]
    shear = [num(r["torsion_shear_ratio"]) for r in rows]
    ke = [num(r["kinetic_energy"]) for r in rows]
    ue = [num(r.get("bonds_elastic_energy")) for r in rows]
    last = rows[-1]
    onset_break = num(last["torsion_break_onset_twist"])
    onset_r = num(last["torsion_resistance_onset_twist"])
    separation = num(last["torsion_separation_twist"])
    # the R-trend onset (configs/torsion_contact.json: resistance_trend_fit_twist > 0), else NaN
    onset_trend = num(last.get("torsion_resistance_trend_onset_twist", "nan"))

    with open(os.path.join(out, "torsion_table.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["twist_rad", "torque_Nm", "elastic_torque_Nm", "shear_stress_over_tau_y", "R_over_R0", "bonds_broken",
                    "kinetic_over_elastic_energy"])
        for k in range(len(rows)):
            w.writerow([tw[k], T[k], Tel[k], shear[k], ratio[k], broken[k], ke[k] / ue[k] if ue[k] > 0 else math.nan])

    with open(os.path.join(out, "torsion_onsets.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["onset", "twist_rad"])
        w.writerows([["first_break", onset_break], ["resistance_rise", onset_r], ["resistance_trend", onset_trend],
                     ["separation", separation]])

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, axb) = plt.subplots(2, 1, figsize=(7, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(tw, T, "k-", label="torque (clamped end)")
    ax.plot(tw, Tel, "k:", label="elastic G J theta / L")
    ax.set_ylabel("torque [N m]")
    ax2 = ax.twinx()
    finite = [(t, r) for t, r in zip(tw, ratio) if math.isfinite(r)]
    if finite:
        ax2.plot([t for t, _ in finite], [r for _, r in finite], "r-", label="R / R0")
    ax2.set_yscale("log")
    ax2.set_ylabel("R / R0 (red)")
    for x, lab, c in [(onset_break, "first break", "b"), (onset_r, "R rise 1 %", "r"),
                      (onset_trend, "R leaves its trend", "g"), (separation, "separation", "m")]:
        if math.isfinite(x):
            ax.axvline(x, color=c, ls="--", lw=0.8, label="%s %.4f rad" % (lab, x))
    ax.legend(loc="upper left", fontsize=8)
    axb.plot(tw, broken, "b-")
    axb.set_ylabel("broken bonds")
    axb.set_xlabel("twist [rad]")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "torsion.png"), dpi=120)

    bpath = os.path.join(a.run_dir, "broken_bonds.csv")
    if os.path.exists(bpath):
        b = read_csv(bpath)
        if b:
            t0 = num(rows[0]["time"])
            w_rate = (tw[-1] - tw[0]) / (num(rows[-1]["time"]) - t0) if len(rows) > 1 else math.nan
            angle = [math.atan2(num(r["y"]), num(r["x"])) for r in b]
            z = [num(r["z"]) for r in b]
            twist = [w_rate * (num(r["time"]) - t0) for r in b]
            with open(os.path.join(out, "torsion_breaks.csv"), "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["angle_rad", "z_m", "twist_at_break_rad"])
                w.writerows(zip(angle, z, twist))
            fig, axc = plt.subplots(figsize=(7, 4))
            sc = axc.scatter(angle, [x * 1e3 for x in z], c=twist, s=4, cmap="viridis")
            fig.colorbar(sc, label="twist at break [rad]")
            axc.set_xlabel("angle around the axis [rad]")
            axc.set_ylabel("z [mm]")
            fig.tight_layout()
            fig.savefig(os.path.join(out, "torsion_breaks.png"), dpi=120)
    print("onset (first break) %.5g rad, resistance rise %.5g rad, R off its trend %.5g rad, separation %.5g rad; "
          "outputs in %s" % (onset_break, onset_r, onset_trend, separation, out))


if __name__ == "__main__":
    main()
