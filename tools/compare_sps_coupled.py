#!/usr/bin/env python3
"""Fully coupled SPS against the same cycle imposed as a prescribed uniform temperature (issue 6).

Usage: compare_sps_coupled.py COUPLED_RUN PRESCRIBED_RUN [--out DIR]

COUPLED_RUN is a run of configs/sps_coupled.json, PRESCRIBED_RUN one of configs/sps_nial_small.json
(same packing seed, mechanics and cycle; the temperature is prescribed by temperature_history).
Reads timeseries.csv, summary.json and the states (h5py; Debian python3-h5py) and writes to --out
(default: COUPLED_RUN/compare):
  comparison.json  energy balance (per stage and over the run), control tracking, densification
                   (porosity_mass against physical time, both runs, and their difference),
                   temperature spread inside the coupled compact, neck-radius distributions at the
                   end of the hot press, run time and its split between modules;
  comparison.md    the same as tables;
  densification.png, necks.png (matplotlib, if installed) and their data, densification.csv
                   (run, cycle time [s], porosity_mass) and necks.csv (run, neck radius [m]).
"""
import argparse
import bisect
import csv
import json
import math
import os
import sys


def read_rows(run):
    with open(os.path.join(run, "timeseries.csv")) as f:
        return list(csv.DictReader(f))


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def stage_rows(rows, summary, name):
    """Rows of the stage called `name` (the timeseries 'stage' column is the stage index)."""
    idx = [k for k, st in enumerate(summary["stages"]) if st["name"] == name]
    if not idx:
        return []
    return [r for r in rows if int(num(r["stage"])) == idx[-1]]


def curve(rows, t0):
    return [(num(r["physical_time"]) - t0, num(r["porosity_mass"])) for r in rows if not math.isnan(num(r["porosity_mass"]))]


def interp(c, t):
    ts = [p[0] for p in c]
    k = bisect.bisect_left(ts, t)
    if k <= 0:
        return c[0][1]
    if k >= len(c):
        return c[-1][1]
    (t0, y0), (t1, y1) = c[k - 1], c[k]
    return y0 + (y1 - y0) * (t - t0) / (t1 - t0) if t1 > t0 else y1


def necks(state_file, group="state/contacts"):
    try:
        import h5py  # noqa: PLC0415
    except ImportError:
        return None
    with h5py.File(state_file, "r") as f:
        cols = f[group + "/state_columns"][()].decode().split("\n")
        k = cols.index("neck_radius")
        a = f[group + "/state"][:, k]
    return sorted(float(x) for x in a if x > 0.0)


def quantiles(v):
    if not v:
        return {}
    q = lambda p: v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))]
    return {"count": len(v), "mean_m": sum(v) / len(v), "p10_m": q(0.1), "median_m": q(0.5), "p90_m": q(0.9), "max_m": v[-1]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("coupled")
    ap.add_argument("prescribed")
    ap.add_argument("--out")
    a = ap.parse_args()
    out = a.out or os.path.join(a.coupled, "compare")
    os.makedirs(out, exist_ok=True)
    sc = json.load(open(os.path.join(a.coupled, "summary.json")))
    sp = json.load(open(os.path.join(a.prescribed, "summary.json")))
    rc, rp = read_rows(a.coupled), read_rows(a.prescribed)
    res = {"coupled_run": a.coupled, "prescribed_run": a.prescribed}

    # Energy balance: per stage (the module's counters restart with each stage) and summed.
    tot = {"joule": 0.0, "lost": 0.0, "fixed": 0.0, "flux": 0.0, "stored": 0.0}
    res["energy"] = {}
    for st in sc["stages"]:
        f = st.get("final", {})
        if "heat_stored_energy" not in f:
            continue
        e = {k: f["heat_" + k + "_energy"] for k in tot}
        for k in tot:
            tot[k] += e[k]
        res["energy"][st["name"]] = dict(e, balance_error=f["heat_balance_error"], electrical_energy_particles_J=f["heat_electrical_energy"])
    scale = abs(tot["joule"]) + abs(tot["flux"]) + abs(tot["lost"]) + abs(tot["fixed"])
    res["energy"]["run"] = dict(tot, balance_error=abs(tot["stored"] - (tot["joule"] + tot["flux"] - tot["lost"] - tot["fixed"])) / scale)

    # Control tracking and temperature spread.
    res["control"] = {}
    for st in sc["stages"]:
        f = st.get("final", {})
        if "controller_max_error_after" not in f:
            continue
        rows = stage_rows(rc, sc, st["name"])
        spread = [num(r["heat_temperature_max"]) - num(r["heat_temperature_min"]) for r in rows]
        std = [num(r["heat_temperature_std"]) for r in rows]
        iso = [num(r["heat_isolated_particles"]) for r in rows]
        ctrl_vs_mean = [num(r["controller_temperature"]) - num(r["heat_temperature_mean"]) for r in rows]
        res["control"][st["name"]] = {
            "max_abs_error_after_track_after_K": f["controller_max_error_after"],
            "final_setpoint_K": f["controller_setpoint"], "final_control_temperature_K": f["controller_temperature"],
            "max_temperature_spread_K": max(spread) if spread else None,
            "final_temperature_spread_K": spread[-1] if spread else None,
            "max_temperature_std_K": max(std) if std else None, "final_temperature_std_K": std[-1] if std else None,
            "final_isolated_particles": iso[-1] if iso else None,
            "max_control_minus_mean_K": max(ctrl_vs_mean, key=abs) if ctrl_vs_mean else None,
            "final_power_W": f["controller_power"], "final_voltage_V": f["controller_voltage"],
        }

    # Densification over the whole cycle (heat stage, then hot press), physical time from the cycle start.
    def cycle_curve(rows, summary, names):
        c = []
        t_base = 0.0
        for nm in names:
            r = stage_rows(rows, summary, nm)
            if not r:
                continue
            t0 = num(r[0]["physical_time"])
            c += [(t_base + t, p) for t, p in curve(r, t0)]
            t_base += next(st["physical_time_s"] for st in summary["stages"] if st["name"] == nm)
        return c
    cc = cycle_curve(rc, sc, ["heat_coupled", "hot_press_coupled"])
    cp = cycle_curve(rp, sp, ["heat", "hot_press"])
    t_end = min(cc[-1][0], cp[-1][0])
    diffs = [(t, p - interp(cp, t)) for t, p in cc if t <= t_end]
    worst = max(diffs, key=lambda d: abs(d[1]))
    res["densification"] = {
        "coupled_final_porosity": cc[-1][1], "prescribed_final_porosity": cp[-1][1],
        "coupled_cycle_time_s": cc[-1][0], "prescribed_cycle_time_s": cp[-1][0],
        "max_abs_porosity_difference": abs(worst[1]), "at_cycle_time_s": worst[0],
    }
    # Necks at the end of the hot press: coupled final state; prescribed: its last hot-press snapshot.
    snaps = sorted(os.listdir(os.path.join(a.prescribed, "snapshots"))) if os.path.isdir(os.path.join(a.prescribed, "snapshots")) else []
    pfile = os.path.join(a.prescribed, "snapshots", snaps[-1]) if snaps else os.path.join(a.prescribed, "final_state.h5")
    nc, npr = necks(os.path.join(a.coupled, "final_state.h5")), necks(pfile)
    res["necks"] = {"coupled": quantiles(nc) if nc else None, "prescribed": quantiles(npr) if npr else None, "prescribed_state": pfile}

    # Run time and its split.
    res["run_time"] = {"coupled_wall_s": sc["wall_time_s"], "prescribed_wall_s": sp["wall_time_s"], "stages": {}}
    for st in sc["stages"]:
        mods = st.get("module_wall_time_s", {})
        res["run_time"]["stages"][st["name"]] = {"wall_s": st.get("wall_time_s"), "steps": st.get("steps"),
                                                 "modules_s": mods,
                                                 "mechanics_and_io_s": (st.get("wall_time_s") or 0.0) - sum(mods.values())}
    json.dump(res, open(os.path.join(out, "comparison.json"), "w"), indent=1)

    md = ["# Coupled SPS against the prescribed-temperature twin", ""]
    md += ["| stage | joule [J] | lost [J] | stored [J] | balance error |", "|---|---|---|---|---|"]
    for k, e in res["energy"].items():
        md.append(f"| {k} | {e['joule']:.4e} | {e['lost']:.4e} | {e['stored']:.4e} | {e['balance_error']:.2e} |")
    md += ["", "| stage | max abs control error after track_after [K] | T std (capacity-weighted) max / final [K] | T_max - T_min final [K] | isolated particles | control - mean [K] |", "|---|---|---|---|---|---|"]
    for k, c in res["control"].items():
        md.append(f"| {k} | {c['max_abs_error_after_track_after_K']:.3f} | {c['max_temperature_std_K']:.2f} / {c['final_temperature_std_K']:.2f} | "
                  f"{c['final_temperature_spread_K']:.1f} | {c['final_isolated_particles']:.0f} | {c['max_control_minus_mean_K']:.2f} |")
    d = res["densification"]
    md += ["", f"Final porosity: coupled {d['coupled_final_porosity']:.4f} at {d['coupled_cycle_time_s']:.1f} s of the cycle, "
               f"prescribed {d['prescribed_final_porosity']:.4f} at {d['prescribed_cycle_time_s']:.1f} s; largest porosity "
               f"difference {d['max_abs_porosity_difference']:.4f} at {d['at_cycle_time_s']:.1f} s.", ""]
    for k in ("coupled", "prescribed"):
        q = res["necks"][k]
        if q:
            md.append(f"Necks ({k}): {q['count']} necks, mean {q['mean_m']*1e6:.3f} um, p10/median/p90 "
                      f"{q['p10_m']*1e6:.3f}/{q['median_m']*1e6:.3f}/{q['p90_m']*1e6:.3f} um.")
    md += ["", "| stage | wall [s] | " + " | ".join(["module split [s]"]) + " |", "|---|---|---|"]
    for k, r in res["run_time"]["stages"].items():
        md.append(f"| {k} | {r['wall_s']:.2f} | " + ", ".join(f"{m} {t:.2f}" for m, t in r["modules_s"].items()) +
                  f", mechanics+I/O {r['mechanics_and_io_s']:.2f} |")
    open(os.path.join(out, "comparison.md"), "w").write("\n".join(md) + "\n")
    with open(os.path.join(out, "densification.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "cycle_time_s", "porosity_mass"])
        w.writerows([["coupled", t, p] for t, p in cc] + [["prescribed", t, p] for t, p in cp])
    with open(os.path.join(out, "necks.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "neck_radius_m"])
        w.writerows([["coupled", x] for x in nc or []] + [["prescribed", x] for x in npr or []])
    try:
        import matplotlib  # noqa: PLC0415
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt  # noqa: PLC0415
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot([t for t, _ in cc], [p for _, p in cc], label="coupled (Joule heating, PI control)")
        ax.plot([t for t, _ in cp], [p for _, p in cp], "--", label="prescribed uniform temperature")
        ax.set_xlabel("cycle time [s]")
        ax.set_ylabel("porosity")
        ax.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(out, "densification.png"), dpi=120)
        if nc and npr:
            fig, ax = plt.subplots(figsize=(6, 4))
            ax.hist([x * 1e6 for x in nc], bins=30, alpha=0.6, label="coupled")
            ax.hist([x * 1e6 for x in npr], bins=30, alpha=0.6, label="prescribed")
            ax.set_xlabel("neck radius [um]")
            ax.set_ylabel("necks")
            ax.legend()
            fig.tight_layout()
            fig.savefig(os.path.join(out, "necks.png"), dpi=120)
    except ImportError:
        pass
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
