#!/usr/bin/env python3
"""The pin's crack in its resistance at every N (issue 20 step 4), from the ledger's torsion runs.

usage: benchmarks/torsion_crack/plot_ensemble.py WORKDIR [-o OUT_DIR]

WORKDIR is the --workdir of `python3 -m tools.validate run --tier full --case seed001/torsion`; its runs
are WORKDIR/full/seed001_torsion/N<n>_seed<s>/out. Writes to OUT_DIR (default: this directory):
  ensemble.png  per N (columns): torque / (G J / L) with the elastic line, R/R0 (log; a separated
                pin, R infinite, is drawn at the top edge) and the broken-bond count against twist,
                one line per packing seed, the prediction 0.0416 rad marked
  ensemble.csv  per run: N, seed, bonds, stiffness ratio, the twists of the first break, of the
                1 % resistance rise, of R doubling (the jump) and of separation, R/R0 at 0.05 /
                0.06 / 0.07 rad, the resistance crossings the 1 mrad persistence filter rejected,
                the largest fall of R/R0 (max so far minus now, over finite values: the rattling
                fluctuation the filter guards against), the bonds broken, wall time
  ensemble_summary.csv  per N: mean and std over the seeds of the same columns
Needs matplotlib (python3-matplotlib).
"""
import argparse
import csv
import glob
import json
import math
import os
import re
import statistics

HERE = os.path.dirname(os.path.abspath(__file__))
PREDICTED = 400e6 * 5e-3 / (48.062e9 * 1e-3)  # tau_y L / (G r) [rad]
COLUMNS = ["stiffness_ratio", "first_break_rad", "resistance_rise_rad", "jump_rad", "separation_rad",
           "R_ratio_0.05", "R_ratio_0.06", "R_ratio_0.07", "rejected_rises", "rejected_jumps",
           "largest_R_fall", "bonds", "bonds_broken", "wall_s"]


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def read_run(run):
    out = os.path.join(run, "out")
    rows = [r for r in csv.DictReader(open(os.path.join(out, "timeseries.csv"))) if r["stage"] == "1"]
    final = json.load(open(os.path.join(out, "summary.json")))["stages"][-1]["final"]
    meta = json.load(open(os.path.join(run, "scenario.meta.json")))
    f = lambda k: math.nan if final.get(k) is None else final[k]
    sep = f("torsion_separation_twist")
    rep = lambda t: math.inf if sep <= t else f("torsion_resistance_ratio_at_%g" % t)
    ratios = [num(r["torsion_resistance_ratio"]) for r in rows]
    fall, peak = 0.0, -math.inf
    for x in ratios:
        if math.isfinite(x):
            peak = max(peak, x)
            fall = max(fall, peak - x)
    return {"rows": rows, "stiffness_ratio": f("torsion_stiffness_ratio"), "first_break_rad": f("torsion_break_onset_twist"),
            "resistance_rise_rad": f("torsion_resistance_onset_twist"), "jump_rad": f("torsion_resistance_jump_twist"),
            "separation_rad": sep, "R_ratio_0.05": rep(0.05), "R_ratio_0.06": rep(0.06), "R_ratio_0.07": rep(0.07),
            "rejected_rises": f("torsion_resistance_rejected_rises"), "rejected_jumps": f("torsion_resistance_rejected_jumps"),
            "largest_R_fall": fall, "bonds": f("bonds"), "bonds_broken": f("bonds_broken"), "wall_s": meta.get("wall_s")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workdir")
    ap.add_argument("-o", "--out", default=HERE)
    a = ap.parse_args()
    runs = {}
    for d in sorted(glob.glob(os.path.join(a.workdir, "full", "seed001_torsion", "N*_seed*"))):
        m = re.search(r"N(\d+)_seed(\d+)$", d)
        if not (m and os.path.exists(os.path.join(d, "out", "summary.json")) and os.path.exists(os.path.join(d, "scenario.meta.json"))):
            continue
        if json.load(open(os.path.join(d, "out", "summary.json"))).get("status") == "completed":
            runs[(int(m.group(1)), int(m.group(2)))] = read_run(d)
    sizes = sorted({n for n, _ in runs})
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "ensemble.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["N", "seed"] + COLUMNS)
        for (n, s), r in sorted(runs.items()):
            w.writerow([n, s] + [r[c] for c in COLUMNS])
    with open(os.path.join(a.out, "ensemble_summary.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["N", "runs"] + [c + suffix for c in COLUMNS for suffix in ("_mean", "_std")])
        for n in sizes:
            rs = [r for (m, _), r in runs.items() if m == n]
            row = [n, len(rs)]
            for c in COLUMNS:
                xs = [r[c] for r in rs if r[c] is not None and not math.isnan(r[c])]
                row += [statistics.fmean(xs) if xs else math.nan, statistics.stdev(xs) if len(xs) > 1 and all(map(math.isfinite, xs)) else math.nan]
            w.writerow(row)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, len(sizes), figsize=(4.2 * len(sizes), 8.5), sharex=True, squeeze=False)
    for col, n in enumerate(sizes):
        ax_t, ax_r, ax_b = axes[0][col], axes[1][col], axes[2][col]
        for (m, s), r in sorted(runs.items()):
            if m != n:
                continue
            tw = [num(x["torsion_twist"]) for x in r["rows"]]
            lw = 1.4 if s == 1 else 0.7
            ax_t.plot(tw, [num(x["torsion_torque_ratio"]) if t > 0 else math.nan for x, t in zip(r["rows"], tw)],
                      lw=lw, label="seed %d" % s)
            rr = [num(x["torsion_resistance_ratio"]) for x in r["rows"]]
            ax_r.plot(tw, [min(x, 1e3) if not math.isnan(x) else math.nan for x in rr], lw=lw)
            ax_b.plot(tw, [num(x["bonds_broken"]) for x in r["rows"]], lw=lw)
        for ax in (ax_t, ax_r, ax_b):
            ax.axvline(PREDICTED, color="k", ls="--", lw=0.8)
        ax_t.axhline(1.0, color="k", ls=":", lw=0.8)
        ax_t.set_ylim(0, 1.6)
        ax_t.set_title("N = %d" % n)
        ax_r.set_yscale("log")
        ax_r.set_ylim(0.9, 2e3)
        ax_b.set_xlabel("twist [rad]")
        if col == 0:
            ax_t.set_ylabel("torque / (G J theta / L)")
            ax_r.set_ylabel("R / R0 (separated: top edge)")
            ax_b.set_ylabel("broken bonds")
            ax_t.legend(fontsize=7)
    fig.suptitle("Pin torsion (configs/torsion_crack.json): dashed = tau_y L / (G r) = %.4f rad" % PREDICTED)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "ensemble.png"), dpi=110)
    print("%d runs at N = %s: %s/ensemble.png, ensemble.csv, ensemble_summary.csv" % (len(runs), sizes, a.out))


if __name__ == "__main__":
    main()
