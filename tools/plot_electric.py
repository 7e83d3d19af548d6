#!/usr/bin/env python3
"""Plot benchmarks/electric_solvers/results.csv: true error against wall time, log-log, one panel
per network family; prints the summary tables of benchmarks/README.md.

    /usr/bin/python3 tools/plot_electric.py [results.csv] [-o out.png] [--target 1e-6]

Error = max(relative error of the effective conductance, max |V - V_ref| / dV). Markers: the
method; colour intensity / labels: network size. Runs with zero error (the reference solve itself)
are drawn at the floor 1e-17. Capped / failed runs have no error and are not drawn. The points
drawn are also written beside the PNG as <png name>_points.csv (family, method, nodes, setting,
wall time [s], error as drawn).
Needs matplotlib (Debian: apt-get install python3-matplotlib) for the PNG only.
"""
import argparse
import csv
import math
import os
import sys

FLOOR = 1e-17


def f(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def load(path):
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["nodes"] = int(r["nodes"])
        for k in ("wall_s", "G_rel_err", "V_max_err", "indicator"):
            r[k] = f(r[k])
        r["err"] = max(r["G_rel_err"], r["V_max_err"])
    return rows


def summary(rows, target):
    print(f"Fastest run with max(G_rel_err, V_max_err) <= {target:g} (wall time incl. set-up):")
    print("| family | nodes | fastest | setting | wall [s] | error | runner-up |")
    print("|---|---|---|---|---|---|---|")
    for fam in sorted({r["family"] for r in rows}):
        for n in sorted({r["nodes"] for r in rows if r["family"] == fam}):
            ok = [r for r in rows if r["family"] == fam and r["nodes"] == n and r["err"] <= target]
            ok.sort(key=lambda r: r["wall_s"])
            if not ok:
                print(f"| {fam} | {n} | none | | | | |")
                continue
            b = ok[0]
            ru = next((f"{r['method']} {r['tolerance_or_beta']} ({r['wall_s']:.3g} s)" for r in ok[1:]
                       if r["method"] != b["method"]), "")
            print(f"| {fam} | {n} | {b['method']} | {b['tolerance_or_beta'] or '-'} | {b['wall_s']:.3g} | "
                  f"{b['err']:.1e} | {ru} |")
    print()
    print("Pseudo-transient (Range indicator, dt = 0.9 x true limit) by beta:")
    print("| family | nodes | beta | status | iterations | indicator | G_rel_err | V_max_err | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["method"] == "pseudo_transient":
            print(f"| {r['family']} | {r['nodes']} | {r['tolerance_or_beta']} | {r['status']} | {r['iterations']} | "
                  f"{r['indicator']:.2e} | {r['G_rel_err']:.2e} | {r['V_max_err']:.2e} | {r['wall_s']:.3g} |")


def plot(rows, png, target):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fams = [x for x in ("packing", "bonded", "sintered") if any(r["family"] == x for r in rows)]
    fams += sorted({r["family"] for r in rows} - set(fams))
    methods = ["direct", "cg_ic", "cg_jacobi", "amg", "pseudo_transient"]
    marker = dict(zip(methods, "*osD^"))
    colour = dict(zip(methods, ["k", "tab:blue", "tab:orange", "tab:green", "tab:red"]))
    sizes = sorted({r["nodes"] for r in rows})
    drawn = []
    fig, axes = plt.subplots(1, len(fams), figsize=(5.2 * len(fams), 4.6), squeeze=False)
    for ax, fam in zip(axes[0], fams):
        for m in methods:
            labelled = False
            for n in sizes:
                pts = [r for r in rows if r["family"] == fam and r["method"] == m and r["nodes"] == n
                       and math.isfinite(r["err"]) and math.isfinite(r["wall_s"])]
                if not pts:
                    continue
                pts.sort(key=lambda r: r["wall_s"])
                x = [r["wall_s"] for r in pts]
                y = [max(r["err"], FLOOR) for r in pts]
                drawn += [[fam, m, n, r["tolerance_or_beta"], r["wall_s"], e] for r, e in zip(pts, y)]
                ax.loglog(x, y, marker=marker[m], color=colour[m], ls="-", lw=0.8, ms=5,
                          alpha=0.35 + 0.65 * (sizes.index(n) + 1) / len(sizes),
                          label=None if labelled else m)
                labelled = True
                ax.annotate(f"{n:.0e}".replace("+0", ""), (x[-1], y[-1]), fontsize=6, color=colour[m])
        ax.axhline(target, color="grey", ls=":", lw=0.8)
        ax.set_title(fam)
        ax.set_xlabel("wall time incl. set-up [s]")
        ax.set_ylabel("true error max(|dG|/G, max|dV|/dV)")
        ax.grid(True, which="major", lw=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Electric network solvers: true error vs time (points at 1e-17 = reference solve)", fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print(f"wrote {png}")
    points = os.path.splitext(png)[0] + "_points.csv"
    with open(points, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["family", "method", "nodes", "tolerance_or_beta", "wall_s", "error_drawn"])
        w.writerows(drawn)
    print(f"wrote {points}")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, "..", "benchmarks", "electric_solvers", "results.csv")
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=default)
    ap.add_argument("-o", "--output", default=None)
    ap.add_argument("--target", type=float, default=1e-6)
    a = ap.parse_args()
    rows = load(a.csv)
    summary(rows, a.target)
    png = a.output or os.path.splitext(a.csv)[0] + ".png"
    try:
        plot(rows, png, a.target)
    except ImportError:
        print("matplotlib not available: no PNG (Debian: apt-get install python3-matplotlib)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
