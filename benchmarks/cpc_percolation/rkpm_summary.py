#!/usr/bin/env python3
"""Summarise runs of the seed 002 RKPM scenarios (configs/cpc_ptc_rkpm*.json, issue 22).

usage: rkpm_summary.py OUTDIR [OUTDIR ...] [--out DIR]

Reads OUTDIR/sweep_<stage>.csv of every finished stage (stage names must differ across OUTDIRs)
and writes into DIR (default: the first OUTDIR)
  rkpm_summary.csv             per stage: items, contacts, RKPM nodes, unknowns (3 per node and per
                               filler), mean / median opening eps0 delta / D at eps0 = 1 % [% of D],
                               fraction of closing contacts, switching strain [%] (mean, sample std,
                               min, max), Z at eps0 = 0 / 0.5 / 1 / 2 %, and where the stage computed
                               it the matrix strain at eps0 = 1 % (volume means of the max principal
                               total / mechanical strain [%], peak bin [%], weight below zero), the
                               largest solve residual and the wall time per configuration [s] (the
                               items' run.log: generation, assembly, solve and the network evaluations)
  rkpm_opening_histogram.csv   bin_lo_pct, bin_hi_pct, one column per stage: fraction of touching
                               contacts per opening bin (percent of D; first / last rows: below /
                               above), averaged over the items
  rkpm_strain_histogram.csv    the same for the max principal strain of the matrix (total_<stage>,
                               mech_<stage>: volume fractions per 0.01 % bin)
  rkpm_strain_histogram.png    the total-strain histograms with the paper's peak (0.03-0.05 %)
and prints the summary. Bin edges come from the configs (make_rkpm_configs.py).
"""
import csv
import glob
import math
import os
import sys

from benchmarks.cpc_percolation.make_rkpm_configs import OPEN_EDGES, STRAIN_EDGES


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def avg(rows, key):
    return sum(num(r[key]) for r in rows) / len(rows)


def stats(xs):
    m = sum(xs) / len(xs)
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else math.nan
    return m, sd


def item_wall_s(item_dir):
    """The wall time of a sweep item from its run.log ("run completed: N steps, T s wall")."""
    try:
        with open(os.path.join(item_dir, "run.log")) as f:
            for line in f:
                if "run completed:" in line:
                    return float(line.split(",")[-1].split()[0])
    except (OSError, ValueError, IndexError):
        pass
    return math.nan


def load(outdirs):
    stages = {}
    for outdir in outdirs:
        for path in sorted(glob.glob(os.path.join(outdir, "sweep_*.csv"))):
            name = os.path.basename(path)[len("sweep_"):-4]
            rows = [r for r in read(path) if r.get("status", "") == "completed"]
            rows = [r for r in rows if not math.isnan(num(r.get("ptc_strain_opening_mean")))]
            for r in rows:
                r["wall_s"] = item_wall_s(os.path.join(outdir, "sweep_" + name, r["item"]))
            if rows:
                stages[name] = rows
    return stages


def histogram(rows, prefix, edges):
    m = len(edges) - 1
    if f"{prefix}_00" not in rows[0]:
        return None
    return ([avg(rows, f"{prefix}_below")] + [avg(rows, f"{prefix}_{k:02d}") for k in range(m)] +
            [avg(rows, f"{prefix}_above")])


def write_histogram(path, edges, columns):
    lo = [-math.inf] + list(edges[:-1]) + [edges[-1]]
    hi = [edges[0]] + list(edges[1:]) + [math.inf]
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["bin_lo_pct", "bin_hi_pct"] + list(columns))
        for k in range(len(lo)):
            w.writerow([f"{100 * lo[k]:.4g}", f"{100 * hi[k]:.4g}"] + [f"{columns[c][k]:.6g}" for c in columns])
    os.replace(tmp, path)


def summary_row(name, rows):
    sw = [100 * num(r["ptc_strain_switching_strain"]) for r in rows]
    m, sd = stats(sw)
    nodes = avg(rows, "ptc_strain_springs")
    fillers = avg(rows, "packing.particles")
    row = {"stage": name, "items": len(rows), "contacts": avg(rows, "ptc_strain_contacts"), "nodes": nodes,
           "unknowns": 3 * (nodes + fillers), "opening_mean_pct": 100 * avg(rows, "ptc_strain_opening_mean"),
           "opening_median_pct": 100 * avg(rows, "ptc_strain_opening_median"),
           "closing_fraction": avg(rows, "ptc_strain_opening_negative_fraction"),
           "switching_strain_pct": m, "switching_strain_std_pct": sd, "switching_min_pct": min(sw),
           "switching_max_pct": max(sw)}
    for e in ("0p00", "0p50", "1p00", "2p00"):
        row[f"Z_{e}pct"] = avg(rows, f"ptc_strain_coordination_{e}pct")
    th = histogram(rows, "ptc_strain_strain_total_hist", STRAIN_EDGES)
    if th is not None:
        k = max(range(len(STRAIN_EDGES) - 1), key=lambda i: th[i + 1])
        row.update({"strain_total_mean_pct": 100 * avg(rows, "ptc_strain_strain_total_mean"),
                    "strain_mech_mean_pct": 100 * avg(rows, "ptc_strain_strain_mech_mean"),
                    "strain_total_peak_pct": 50 * (STRAIN_EDGES[k] + STRAIN_EDGES[k + 1]),
                    "strain_total_negative": avg(rows, "ptc_strain_strain_total_negative_fraction")})
    row["max_solve_residual"] = max(num(r["ptc_strain_solve_residual"]) for r in rows)
    row["wall_s_per_configuration"] = sum(num(r["wall_s"]) for r in rows) / len(rows)
    return row


def plot(path, columns):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no plot")
        return
    centres = [50 * (STRAIN_EDGES[k] + STRAIN_EDGES[k + 1]) for k in range(len(STRAIN_EDGES) - 1)]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.axvspan(0.03, 0.05, color="0.85", label="paper: peak 0.03-0.05 %")
    for name, h in columns.items():
        if name.startswith("total_"):
            ax.plot(centres, h[1:-1], label=name[len("total_"):])
    ax.set_xlabel("max principal strain of the matrix at eps0 = 1 % [%]")
    ax.set_ylabel("volume fraction per 0.01 % bin")
    ax.set_xlim(-0.3, 1.2)
    ax.legend(fontsize=7)
    fig.tight_layout()
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, path)


def main():
    args = sys.argv[1:]
    if not args or args[0].startswith("-"):
        print(__doc__)
        return 2
    dest = args[args.index("--out") + 1] if "--out" in args else args[0]
    outdirs = [a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] != "--out")]
    stages = load(outdirs)
    if not stages:
        print("no finished stage in", outdirs)
        return 1
    summary = [summary_row(n, rows) for n, rows in stages.items()]
    head = []
    for r in summary:
        head += [k for k in r if k not in head]
    tmp = os.path.join(dest, "rkpm_summary.csv.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=head)
        w.writeheader()
        w.writerows(summary)
    os.replace(tmp, os.path.join(dest, "rkpm_summary.csv"))
    write_histogram(os.path.join(dest, "rkpm_opening_histogram.csv"), OPEN_EDGES,
                    {n: histogram(rows, "ptc_strain_opening_hist", OPEN_EDGES) for n, rows in stages.items()})
    strain = {}
    for n, rows in stages.items():
        for kind in ("total", "mech"):
            h = histogram(rows, f"ptc_strain_strain_{kind}_hist", STRAIN_EDGES)
            if h is not None:
                strain[f"{kind}_{n}"] = h
    if strain:
        write_histogram(os.path.join(dest, "rkpm_strain_histogram.csv"), STRAIN_EDGES, strain)
        plot(os.path.join(dest, "rkpm_strain_histogram.png"), strain)
    print(",".join(head))
    for r in summary:
        print(",".join(f"{r[k]:.4g}" if isinstance(r.get(k), float) else str(r.get(k, "")) for k in head))
    return 0


if __name__ == "__main__":
    sys.exit(main())
