#!/usr/bin/env python3
"""Summarise a run of configs/cpc_ptc_rkpm.json (bonded network vs RKPM continuum, seed 002).

usage: rkpm_summary.py OUTDIR [--out DIR]

Reads OUTDIR/sweep_<stage>.csv of every stage that finished and writes
  DIR/rkpm_opening_histogram.csv   bin_lo_pct, bin_hi_pct, then one column per stage: the fraction
                                   of touching contacts whose opening eps0 delta / D at eps0 = 1 %
                                   lies in the bin (bins in percent of D; the first/last rows are
                                   the below/above columns), averaged over the stage's items
  DIR/rkpm_summary.csv             per stage: items, contacts, mean and median opening at 1 % [% of D],
                                   negative fraction, switching strain [%] (mean, sample std)
and prints both tables. The bin edges are those of the config (-0.2 % to 1 % of D, 0.02 % wide).
"""
import csv
import glob
import math
import os
import sys


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def main():
    args = sys.argv[1:]
    if not args:
        print(__doc__)
        return 2
    outdir = args[0]
    dest = args[args.index("--out") + 1] if "--out" in args else outdir
    edges = [-0.002 + 0.0002 * k for k in range(61)]
    stages = {}
    for path in sorted(glob.glob(os.path.join(outdir, "sweep_*.csv"))):
        rows = [r for r in read(path) if r.get("status", "ok") in ("ok", "done", "completed", "")]
        rows = [r for r in rows if not math.isnan(num(r.get("ptc_strain_opening_mean")))]
        if rows:
            stages[os.path.basename(path)[len("sweep_"):-4]] = rows
    names = list(stages)
    hist = []
    for k in range(60):
        hist.append([100 * edges[k], 100 * edges[k + 1]] +
                    [sum(num(r[f"ptc_strain_opening_hist_{k:02d}"]) for r in stages[n]) / len(stages[n]) for n in names])
    below = [-math.inf, 100 * edges[0]] + [sum(num(r["ptc_strain_opening_hist_below"]) for r in stages[n]) / len(stages[n]) for n in names]
    above = [100 * edges[-1], math.inf] + [sum(num(r["ptc_strain_opening_hist_above"]) for r in stages[n]) / len(stages[n]) for n in names]
    with open(os.path.join(dest, "rkpm_opening_histogram.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["bin_lo_pct", "bin_hi_pct"] + names)
        for row in [below] + hist + [above]:
            w.writerow([f"{v:.4g}" for v in row])
    summary = []
    for n in names:
        rows = stages[n]
        sw = [100 * num(r["ptc_strain_switching_strain"]) for r in rows]
        m = sum(sw) / len(sw)
        sd = math.sqrt(sum((x - m) ** 2 for x in sw) / (len(sw) - 1)) if len(sw) > 1 else math.nan
        peak = max(range(60), key=lambda k: sum(num(r[f"ptc_strain_opening_hist_{k:02d}"]) for r in rows))
        summary.append([n, len(rows), sum(num(r["ptc_strain_contacts"]) for r in rows) / len(rows),
                        100 * sum(num(r["ptc_strain_opening_mean"]) for r in rows) / len(rows),
                        100 * sum(num(r["ptc_strain_opening_median"]) for r in rows) / len(rows),
                        sum(num(r["ptc_strain_opening_negative_fraction"]) for r in rows) / len(rows),
                        f"{100 * edges[peak]:.2f}..{100 * edges[peak + 1]:.2f}", m, sd,
                        max(num(r["ptc_strain_solve_residual"]) for r in rows)])
    head = ["stage", "items", "contacts", "opening_mean_pct_at_1pct", "opening_median_pct_at_1pct", "negative_fraction",
            "histogram_peak_pct", "switching_strain_pct", "switching_strain_std_pct", "max_solve_residual"]
    with open(os.path.join(dest, "rkpm_summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head)
        w.writerows(summary)
    print(",".join(head))
    for s in summary:
        print(",".join(str(v) if not isinstance(v, float) else f"{v:.4g}" for v in s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
