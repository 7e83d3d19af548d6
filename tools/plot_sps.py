#!/usr/bin/env python3
"""Plots and validation table of an SPS pipeline run (e.g. configs/sps_nial_small.json).

    /usr/bin/python3 -m tools.plot_sps RUN_DIR [-o OUT_DIR] [--press-stage hot_press]
        [--gb-stage conductivity_gb] [--no-gb-stage conductivity_no_gb] [--stages a,b,c]

RUN_DIR is the output directory of `sparkdem run` (summary.json, timeseries.csv, the snapshot
files). Writes into OUT_DIR (default RUN_DIR):
  conductivity_vs_porosity.png  kappa_eff of each snapshot against its porosity, one series per
                                conductivity sweep stage, the measured NiAl samples (seed 000
                                Table 1) with a +-5 % band and the bulk kappa_0;
  neck_histograms.png           per snapshot the histogram of a / r_min over the sintered necks
                                (10 bins on [0, 1], % of necks; seed 000 Fig. 6) of the contact
                                law's neck_radius; the network conducts through the CV necks
                                after Eq. 25, summarised by its network_neck_* columns;
  densification.png             porosity against physical time and against temperature during
                                the hot press, the snapshots marked;
  calibration_map.png           kappa_eff of the calibration snapshot over (delta_gb, epsilon)
                                (seed 000 Fig. 9), when the run calibrated gb_thickness;
  sps_table.csv                 per snapshot target: porosity taken, kappa_eff of each stage,
                                measured kappa, relative error [%], the Hashin-Shtrikman upper
                                bound kappa_b 2(1-p)/(2+p) at the porosity taken and each stage's
                                kappa over it (> 1 violates the bound), the snapshot's quasi-static
                                gates (issue 36, tools/sps_outputs.GATES: kinetic energy / punch
                                work, core - compact mass porosity, envelope / die radius, fullest
                                and last neck bin, median a / r_min; all passed: yes/no, empty
                                when the stage lacks "compact" or "necks"); then each stage's wall time.
Each PNG comes with the data drawn in it, as CSV of the same name beside it:
  conductivity_vs_porosity.csv  series (stage, measured, bulk), snapshot, porosity, kappa_eff
                                [S/m], the +-5 % band of the measured points;
  neck_histograms.csv           snapshot, target and taken porosity, necks, bin edges of
                                a / r_min, % of necks in the bin, the snapshot's median a / r_min
                                and % of necks in the last bin (0.9-1);
  densification.csv             kind (row / snapshot), simulation time [s], physical time [s],
                                temperature [K], porosity_mass, porosity (snapshot rows: the
                                value taken, placed by interpolation in time as in the plot);
  calibration_map.csv           kind (scan: the evaluated points at the run's epsilon; map: the
                                drawn grid), delta_gb [m], epsilon, kappa_eff [S/m] (empty
                                outside the scan).
The table is also printed. Snapshots not reached (summary.json "not_reached") are reported and
skipped. Conductivity stages: sweeps over the press stage's snapshots whose rows have
electrical_conductivity_eff (all of them unless --stages is given); --gb-stage / --no-gb-stage name
the series with / without the grain-boundary layer (by default the stages so named, else the
stage whose name contains "no_gb" and the one that contains "gb" but not "no_gb").
Needs numpy, matplotlib and h5py (Debian python3-matplotlib python3-h5py).
"""
import argparse
import csv
import json
import math
import os
import sys

import numpy as np

from tools import sps_outputs as so
from tools.sps_outputs import NECK_BINS, calibration, find_stage, neck_histogram, neck_ratios, sweep_values

KAPPA_COLUMN = "electrical_conductivity_eff"
KAPPA_BULK = 9.8e6  # S/m, NiAl
# Measured NiAl samples (seed 000 Table 1): porosity -> effective conductivity [S/m].
MEASURED = {0.216: 4.33e6, 0.164: 6.14e6, 0.106: 7.44e6, 0.050: 8.77e6}
BAND = 0.05


class InputError(Exception):
    pass


def hashin_shtrikman_upper(porosity, kappa_bulk=KAPPA_BULK):
    """Hashin-Shtrikman upper bound of a porous body with insulating pores [S/m]:
    kappa_b 2 (1 - p) / (2 + p) (Hashin & Shtrikman 1962, J. Appl. Phys. 33, 3125, with a zero-
    conductivity second phase). No isotropic body of bulk kappa_b and porosity p conducts more."""
    return kappa_bulk * 2.0 * (1.0 - porosity) / (2.0 + porosity)


def measured_at(porosity):
    """Measured kappa of the sample at this (target) porosity, or None."""
    return next((k for p, k in MEASURED.items() if abs(p - porosity) < 1e-9), None)


def load_json(path):
    if not os.path.isfile(path):
        raise InputError(f"missing {path}")
    with open(path) as fh:
        return json.load(fh)


def conductivity_stages(summary, press, chosen):
    """Names of the sweep stages over the press stage's snapshots that report kappa_eff."""
    names = []
    for st in summary["stages"]:
        sw = st.get("sweep", {})
        if sw.get("snapshots_of") == press and any(KAPPA_COLUMN in r.get("values", {}) for r in sw.get("rows", [])):
            names.append(st["name"])
    if chosen:
        unknown = [n for n in chosen if n not in names]
        if unknown:
            raise InputError(f"--stages: {', '.join(unknown)} not among the conductivity stages ({', '.join(names) or 'none'})")
        names = chosen
    if not names:
        raise InputError(f"no sweep stage over the snapshots of '{press}' reports {KAPPA_COLUMN}")
    return names


def pick(names, given, default, match):
    """The stage named `given` (must exist), else `default` if present, else the first that matches."""
    if given:
        if given not in names:
            raise InputError(f"stage '{given}' is not among the conductivity stages ({', '.join(names)})")
        return given
    if default in names:
        return default
    return next((n for n in names if match(n)), None)


def load_run(a):
    run = a.run_dir
    summary = load_json(os.path.join(run, "summary.json"))
    ts_path = os.path.join(run, "timeseries.csv")
    if not os.path.isfile(ts_path):
        raise InputError(f"missing {ts_path}")
    names = [s["name"] for s in summary.get("stages", [])]
    if a.press_stage not in names:
        raise InputError(f"no stage '{a.press_stage}' in summary.json (stages: {', '.join(names)}); see --press-stage")
    press_index = names.index(a.press_stage)
    snap = find_stage(summary, a.press_stage).get("snapshots")
    if not snap or not snap.get("taken"):
        raise InputError(f"stage '{a.press_stage}' took no snapshots")
    snap["taken"] = [s for s in snap["taken"] if s.get("value") is not None]  # porosity not finite: nothing to plot
    for s in snap["taken"]:
        if not os.path.isfile(os.path.join(run, s["file"])):
            raise InputError(f"missing snapshot file {os.path.join(run, s['file'])}")
    stages = conductivity_stages(summary, a.press_stage, [x for x in (a.stages or "").split(",") if x])
    gb = pick(stages, a.gb_stage, "conductivity_gb", lambda n: "gb" in n and "no_gb" not in n)
    no_gb = pick(stages, a.no_gb_stage, "conductivity_no_gb", lambda n: "no_gb" in n)
    with open(ts_path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r.get("stage") == str(press_index)]
    if not rows:
        raise InputError(f"timeseries.csv has no rows of stage {press_index} ('{a.press_stage}')")
    for c in ("time", "physical_time", "temperature", "porosity_mass"):
        if c not in rows[0]:
            raise InputError(f"timeseries.csv has no column '{c}'")
    return {"summary": summary, "snap": snap, "rows": rows, "stages": stages, "gb": gb, "no_gb": no_gb,
            "kappa": {n: sweep_values(summary, n, KAPPA_COLUMN) for n in stages}}


def write_csv(path, header, rows):
    """The data behind a plot: `header`, then `rows` (None and NaN written as empty cells)."""
    def cell(x):
        return "" if x is None or (isinstance(x, float) and math.isnan(x)) else x
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows([cell(x) for x in r] for r in rows)


def column(rows, name):
    return np.array([float(r[name]) if r[name] not in ("", None) else math.nan for r in rows])


def label(d, name):
    if name == d["gb"]:
        return f"{name} (with grain-boundary layer)"
    if name == d["no_gb"]:
        return f"{name} (without layer)"
    return name


def plot_conductivity(d, plt, path, csv_path):
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    by_index = {s["index"]: s for s in d["snap"]["taken"]}
    data = []
    for name, marker in zip(d["stages"], "os^Dv<>p*h"):
        pts = sorted((by_index[k]["value"], v, k) for k, v in d["kappa"][name].items() if k in by_index and v is not None)
        if pts:
            x, y, _ = zip(*pts)
            ax.plot(x, y, marker=marker, label=label(d, name))
        data += [[name, k, x, y, None, None] for x, y, k in pts]
    p = np.array(sorted(MEASURED))
    k = np.array([MEASURED[x] for x in p])
    data += [["measured (seed 000 Table 1)", None, x, y, y * (1 - BAND), y * (1 + BAND)] for x, y in zip(p, k)]
    data.append(["bulk kappa_0", None, None, KAPPA_BULK, None, None])
    write_csv(csv_path, ["series", "snapshot", "porosity", "kappa_eff_S_per_m", "band_low_S_per_m", "band_high_S_per_m"], data)
    ax.fill_between(p, k * (1 - BAND), k * (1 + BAND), color="0.8", label=f"measured ±{100 * BAND:g} %")
    ax.plot(p, k, "k*", ms=10, ls="none", label="measured NiAl (seed 000 Table 1)")
    ax.axhline(KAPPA_BULK, color="k", ls="--", lw=1, label=f"bulk κ0 = {KAPPA_BULK:.3g} S/m")
    ax.set_xlabel("porosity (snapshot, porosity_mass)")
    ax.set_ylabel("κ_eff [S/m]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_necks(d, run, plt, path, csv_path):
    taken = d["snap"]["taken"]
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    width = 0.9 / NECK_BINS / len(taken)
    centres = (np.arange(NECK_BINS) + 0.5) / NECK_BINS
    data = []
    for j, s in enumerate(taken):
        x = neck_ratios(os.path.join(run, s["file"]))
        percent = 100 * neck_histogram(x)
        ax.bar(centres + (j - (len(taken) - 1) / 2) * width, percent, width,
               label=f"porosity {s['value']:.3f} ({x.size} necks)")
        median = float(np.median(x)) if x.size else math.nan
        data += [[s["index"], s.get("target"), s["value"], x.size, b / NECK_BINS, (b + 1) / NECK_BINS, percent[b], median,
                  percent[-1]] for b in range(NECK_BINS)]
    write_csv(csv_path, ["snapshot", "target_porosity", "porosity", "necks", "a_over_rmin_low", "a_over_rmin_high", "percent_of_necks",
                         "median_a_over_rmin", "percent_in_last_bin"], data)
    ax.set_xticks(np.linspace(0, 1, NECK_BINS + 1))
    ax.set_xlim(0, 1)
    ax.set_xlabel("a / r_min: the sintering law's neck (the network's necks: network_neck_* columns)")
    ax.set_ylabel("necks [%]")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_densification(d, press, plt, path, csv_path):
    rows = d["rows"]
    t, T, sim_t = column(rows, "physical_time"), column(rows, "temperature"), column(rows, "time")
    series = [c for c in ("porosity_mass", "porosity") if c in rows[0]]
    taken = d["snap"]["taken"]
    # Snapshots are taken between timeseries rows: place them by their simulation time.
    st_ = np.array([s["time"] for s in taken])
    sv = np.array([s["value"] for s in taken])
    snap_col = d["snap"].get("column", "porosity_mass")
    values = {c: column(rows, c) for c in series}
    data = [["row", sim_t[k], t[k], T[k]] + [values[c][k] for c in series] for k in range(len(rows))]
    for tk, v, pt, pT in zip(st_, sv, np.interp(st_, sim_t, t), np.interp(st_, sim_t, T)):
        data.append(["snapshot", tk, pt, pT] + [v if c == snap_col else None for c in series])
    write_csv(csv_path, ["kind", "time_s", "physical_time_s", "temperature_K"] + series, data)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for ax, xs, xlabel in ((axes[0], t, "physical time [s]"), (axes[1], T, "temperature [K]")):
        for c in series:
            ax.plot(xs, column(rows, c), label=c)
        ax.plot(np.interp(st_, sim_t, xs), sv, "ko", mfc="none", label=f"snapshots ({d['snap'].get('column', '')})")
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("porosity")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"densification during '{press}'")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def gb_epsilon(run, stage):
    """gb_epsilon of the electrical module of `stage` as run (resolved.json)."""
    res = load_json(os.path.join(run, "resolved.json"))
    st = next(s for s in res["stages"] if s.get("name") == stage)
    return float(st["modules"]["electrical_network"]["gb_epsilon"])


def plot_calibration(d, run, plt, path, csv_path):
    """Seed 000 Fig. 9: kappa_eff of the calibration snapshot over (delta_gb, epsilon) (delta_gb from
    0.1 um to 0.3 um or 1.25x the calibrated value, epsilon 0.1-0.5). Only the ratio
    epsilon / delta_gb enters the layer conductance (Eq. 26), so the map is the scanned curve
    kappa(delta_gb at the run's epsilon) read at delta_gb * epsilon_run / epsilon (ln-ln
    interpolation between scanned points; blank outside the scan)."""
    cal = calibration(d["summary"], d["gb"])
    if not cal or not cal.get("map") or not cal["parameter"].endswith("/gb_thickness"):
        return False
    eps_run = gb_epsilon(run, d["gb"])
    pts = sorted(cal["map"])
    lx, ly = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    # The seed's ranges (delta_gb 0.1-0.3 um), widened to show the calibrated point.
    delta = np.linspace(0.1e-6, max(0.3e-6, 1.25 * (cal.get("value") or 0.0)), 81)
    eps = np.linspace(0.1, 0.5, 81)
    D, E = np.meshgrid(delta, eps)
    x = np.log(D * eps_run / E)
    K = np.exp(np.interp(x, lx, ly, left=np.nan, right=np.nan))
    data = [["scan", p[0], eps_run, p[1]] for p in pts]
    data += [["map", dg, e, k] for dg, e, k in zip(D.ravel(), E.ravel(), K.ravel())]
    write_csv(csv_path, ["kind", "delta_gb_m", "epsilon", "kappa_eff_S_per_m"], data)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    cs = ax.contourf(D * 1e6, E, K / 1e6, levels=20, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="kappa_eff [1e6 S/m]")
    t = cal["target"]
    ax.contour(D * 1e6, E, K, levels=[0.95 * t, 1.05 * t], colors="w", linestyles="--")
    ax.contour(D * 1e6, E, K, levels=[t], colors="w")
    if cal.get("value") is not None:
        ax.plot([cal["value"] * 1e6], [eps_run], "r*", ms=12, label=f"calibrated: delta_gb = {cal['value'] * 1e6:.3g} um at eps = {eps_run:g}")
        ax.legend(loc="upper left", fontsize=8)
    ax.set_xlabel("delta_gb [um]")
    ax.set_ylabel("epsilon")
    ax.set_title(f"calibration snapshot {cal['snapshot']}: target {t:.3g} S/m (white: target and +-5 %)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def table(d):
    """Rows of sps_table.csv: one per snapshot target, then one per stage (wall time)."""
    stages = d["stages"]
    head = (["row", "target_porosity", "porosity_taken"] + [f"kappa_{n} [S/m]" for n in stages]
            + ["kappa_measured [S/m]"] + [f"rel_err_{n} [%]" for n in stages]
            + ["hashin_shtrikman_upper [S/m]"] + [f"{n}_over_bound" for n in stages] + [f"qs_{g}" for g in so.QUANTITIES]
            + ["qs_gates_pass", "wall_time_s"])
    by_target = {s.get("target"): s for s in d["snap"]["taken"]}
    targets = sorted(set(by_target) | set(d["snap"].get("not_reached", [])) - {None}, reverse=True)
    out = [head]
    for p in targets:
        s = by_target.get(p)
        km = measured_at(p)
        ks = [d["kappa"][n].get(s["index"]) if s else None for n in stages]
        out.append(["snapshot", f"{p:g}", f"{s['value']:.4f}" if s else "not reached"]
                   + [f"{k:.4g}" if k is not None else "" for k in ks]
                   + [f"{km:.4g}" if km else ""]
                   + [f"{100 * (k / km - 1):+.1f}" if k is not None and km else "" for k in ks])
        hs = hashin_shtrikman_upper(s["value"]) if s else None
        out[-1] += [f"{hs:.4g}" if hs else ""] + [f"{k / hs:.3f}" if k is not None and hs else "" for k in ks]
        g = so.quasi_static_gates(s.get("columns", {})) if s else {}
        verdicts = [g.get(n + "_pass") for n in so.GATES]
        out[-1] += ([f"{g[n]:.4g}" if g.get(n) is not None else "" for n in so.QUANTITIES]
                    + ["" if not s or None in verdicts else ("yes" if all(verdicts) else "no")] + [""])
    for st in d["summary"]["stages"]:
        out.append([f"stage {st['name']}"] + [""] * (len(head) - 2) + [f"{st.get('wall_time_s', math.nan):.2f}"])
    return out


def print_table(rows):
    """The snapshot rows as aligned columns (without the wall-time column), then the wall times."""
    snaps = [r[:-1] for r in rows if not r[0].startswith("stage ")]
    w = [max(len(r[i]) for r in snaps) for i in range(len(snaps[0]))]
    for r in snaps:
        print("  ".join(x.ljust(n) for x, n in zip(r, w)).rstrip())
    for r in rows:
        if r[0].startswith("stage "):
            print(f"{r[0]}: wall time {r[-1]} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run_dir", help="output directory of the pipeline run")
    ap.add_argument("-o", "--outdir", help="where to write the PNGs, their CSVs and sps_table.csv (default: run_dir)")
    ap.add_argument("--press-stage", default="hot_press", help="name of the hot-press stage (default hot_press)")
    ap.add_argument("--gb-stage", help="conductivity stage with the grain-boundary layer (default conductivity_gb)")
    ap.add_argument("--no-gb-stage", help="conductivity stage without the layer (default conductivity_no_gb)")
    ap.add_argument("--stages", help="comma-separated conductivity stages to plot (default: all)")
    a = ap.parse_args()
    try:
        d = load_run(a)
    except InputError as e:
        print(f"plot_sps.py: {a.run_dir}: {e}", file=sys.stderr)
        return 2
    out = a.outdir or a.run_dir
    os.makedirs(out, exist_ok=True)
    for p in d["snap"].get("not_reached", []):
        print(f"snapshot at porosity {p:g} not reached in this run: skipped")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = [os.path.join(out, f) for f in ("conductivity_vs_porosity.png", "neck_histograms.png", "densification.png",
                                             "sps_table.csv")]
    data = [os.path.splitext(p)[0] + ".csv" for p in paths[:3]]  # the data of each plot beside it
    plot_conductivity(d, plt, paths[0], data[0])
    plot_necks(d, a.run_dir, plt, paths[1], data[1])
    plot_densification(d, a.press_stage, plt, paths[2], data[2])
    paths += data
    cal_png = os.path.join(out, "calibration_map.png")
    if plot_calibration(d, a.run_dir, plt, cal_png, os.path.splitext(cal_png)[0] + ".csv"):
        paths += [cal_png, os.path.splitext(cal_png)[0] + ".csv"]
        cal = calibration(d["summary"], d["gb"])
        print(f"calibration: {cal['parameter']} = {cal['value']:.6g} gives {cal['column']} = {cal['achieved']:.6g} "
              f"(target {cal['target']:.6g}; {len(cal['map'])} evaluated points, {cal['search_items']} search items)")
    rows = table(d)
    with open(paths[3], "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    print_table(rows)
    for p in paths:
        print("wrote", p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
