#!/usr/bin/env python3
"""Pyroresistive (PTC) outputs of seed-002 CPC runs (ptc_strain, ptc_self_heating).

  plot_ptc.py strain OUT --prefix PREFIX
      reads OUT/summary.json and the sweep tables OUT/sweep_<stage>.csv of a ptc_strain run
      (configs/cpc_ptc_strain.json, configs/cpc_ptc_temperature.json) and writes, per stage,
        PREFIX_<stage>_eps0.csv   per listed eps0: configurations, spanning fraction, mean Z and its
                                  standard error, mean rho over the spanning configurations (and
                                  their number), the same for log10 rho
        PREFIX_<stage>_T.csv      the same per listed temperature, with eps0(T) (temperature runs)
        PREFIX_<stage>_switch.csv per configuration: switching strain [1], switching temperature [K]
        PREFIX_<stage>.png        Z and rho against eps0 (and against T when present)
  plot_ptc.py openings OUT --prefix PREFIX [--eps0 0.01]
      reads the per-contact results /networks/ptc_contacts of the frames OUT/frames/*.h5 (the
      initial gap, the unit opening delta [m per unit eps0] of every touching contact) and writes
        PREFIX_openings.csv       per contact: frame, ids, D = R_i + R_j, gap / D, the contact
                                  strain eps0 delta / D at --eps0, break strain
        PREFIX_openings.png       histogram of the contact strain at --eps0 (the paper's Fig. 4
                                  analogue: the opening of touching pairs over D)
  plot_ptc.py heating OUT [OUT ...] --prefix PREFIX
      reads OUT/timeseries.csv of self-heating runs (configs/cpc_self_heating.json) and writes
        PREFIX_heating.csv        time, current, resistance, mean and max temperature, conducting
                                  contacts, per run
        PREFIX_heating.png        current and temperature against time
Every CSV and PNG is written under a temporary name and renamed (atomic). numpy, matplotlib, h5py.
"""
import argparse
import csv
import glob
import json
import math
import os
import re
import sys


def atomic_csv(path, header, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow(r)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def atomic_png(fig, path):
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    os.replace(tmp, path)


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def stats(xs):
    xs = [x for x in xs if math.isfinite(x)]
    n = len(xs)
    if n == 0:
        return float("nan"), float("nan"), 0
    m = sum(xs) / n
    se = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1) / n) if n > 1 else float("nan")
    return m, se, n


def sweep_tables(out):
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    for st in summary["stages"]:
        if "sweep" not in st:
            continue
        with open(os.path.join(out, st["sweep"]["table"])) as f:
            rows = [r for r in csv.DictReader(f) if r.get("status", "completed") == "completed"]
        yield st["name"], rows


def eps_of(sfx):
    # "2p85pct" -> 0.0285
    return float(sfx.replace("pct", "").replace("p", ".")) / 100.0


def T_of(sfx):
    # "T403p15K" -> 403.15
    return float(sfx[1:-1].replace("p", "."))


def cmd_strain(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for stage, rows in sweep_tables(a.out):
        if not rows:
            continue
        cols = rows[0].keys()
        eps_sfx = sorted({m.group(1) for c in cols for m in [re.match(r"ptc_strain_coordination_(\d+p\d+pct)$", c)] if m}, key=eps_of)
        T_sfx = sorted({m.group(1) for c in cols for m in [re.match(r"ptc_strain_coordination_(T\d+p\d+K)$", c)] if m}, key=T_of)

        def block(sfx_list, key_of, with_eps):
            out = []
            for s in sfx_list:
                Z = [num(r["ptc_strain_coordination_" + s]) for r in rows]
                rho = [num(r["ptc_strain_resistivity_" + s]) for r in rows]
                span = [x for x in rho if math.isfinite(x) and x > 0]
                zm, zse, n = stats(Z)
                rm, rse, ns = stats(span)
                lm, lse, _ = stats([math.log10(x) for x in span])
                row = [key_of(s)]
                if with_eps:
                    row.append(stats([num(r["ptc_strain_eps0_" + s]) for r in rows])[0])
                row += [n, ns / n if n else float("nan"), zm, zse, rm, rse, ns, lm, lse]
                out.append(row)
            return out

        head = ["configurations", "spanning_fraction", "Z_mean", "Z_se", "rho_mean_spanning", "rho_se", "spanning",
                "log10_rho_mean", "log10_rho_se"]
        E = block(eps_sfx, eps_of, False)
        atomic_csv("%s_%s_eps0.csv" % (a.prefix, stage), ["eps0"] + head, E)
        TT = block(T_sfx, T_of, True) if T_sfx else []
        if TT:
            atomic_csv("%s_%s_T.csv" % (a.prefix, stage), ["T_K", "eps0"] + head, TT)
        sw = [[k, num(r.get("ptc_strain_switching_strain")), num(r.get("ptc_strain_switching_temperature"))] for k, r in enumerate(rows)]
        atomic_csv("%s_%s_switch.csv" % (a.prefix, stage), ["configuration", "switching_strain", "switching_temperature_K"], sw)
        es = stats([x[1] for x in sw])
        ts = stats([x[2] for x in sw])
        print("%s: switching strain %.4f +- %.4f (SE, %d), switching temperature %.2f +- %.2f K" % (stage, es[0], es[1], es[2], ts[0], ts[1]))
        ncol = 2 if TT else 1
        fig, ax = plt.subplots(2, ncol, figsize=(5.5 * ncol, 7), squeeze=False)
        for c, (data, xlab, off) in enumerate([(E, "matrix eigenstrain eps0 [%]", 0)] + ([(TT, "temperature T [K]", 1)] if TT else [])):
            x = [r[0] * (100.0 if off == 0 else 1.0) for r in data]
            k = 1 + off
            ax[0][c].errorbar(x, [r[k + 2] for r in data], yerr=[r[k + 3] for r in data], marker="o", ms=3)
            ax[0][c].set_ylabel("mean coordination Z")
            ax[0][c].set_xlabel(xlab)
            ax[1][c].errorbar(x, [10 ** r[k + 7] if math.isfinite(r[k + 7]) else float("nan") for r in data], marker="s", ms=3)
            ax[1][c].set_yscale("log")
            ax[1][c].set_ylabel("rho (geometric mean, spanning configs)")
            ax[1][c].set_xlabel(xlab)
            if off == 0 and math.isfinite(es[0]):
                ax[1][c].axvline(100 * es[0], color="r", ls="--", label="switching strain %.2f %%" % (100 * es[0]))
                ax[1][c].legend()
            if off == 1 and math.isfinite(ts[0]):
                ax[1][c].axvline(ts[0], color="r", ls="--", label="switching T %.1f K" % ts[0])
                ax[1][c].legend()
        fig.suptitle("ptc_strain, stage %s (%d configurations)" % (stage, len(rows)))
        atomic_png(fig, "%s_%s.png" % (a.prefix, stage))
        plt.close(fig)


def cmd_openings(a):
    import h5py
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    files = sorted(glob.glob(os.path.join(a.out, "**", "frames", "*.h5"), recursive=True))
    rows = []
    for fn in files:
        with h5py.File(fn, "r") as f:
            groups = []
            f.visit(lambda name: groups.append(name) if name.endswith("networks/ptc_contacts") else None)
            for g in groups:
                net = f[g]
                frame = os.path.relpath(fn, a.out) + ":" + g
                # particle radii by id from the same frame
                base = g[: -len("networks/ptc_contacts")]
                parts = f[base + "particles"] if (base + "particles") in f else None
                if parts is None:
                    continue
                rid = dict(zip(np.ravel(parts["id"][()]).tolist(), np.ravel(parts["radius"][()]).tolist()))
                pairs = net["pairs"][()].reshape(-1, 2)
                gap = np.ravel(net["gap"][()])
                op = np.ravel(net["unit_opening"][()])
                eb = np.ravel(net["break_strain"][()])
                # the touching contacts only (issue 60: the closing candidates are listed beside them)
                touching = np.ravel(net["touching"][()]) if "touching" in net else np.ones(len(gap))
                for k in range(len(gap)):
                    if touching[k] < 0.5:
                        continue
                    D = rid[int(pairs[k, 0])] + rid[int(pairs[k, 1])]
                    rows.append([frame, int(pairs[k, 0]), int(pairs[k, 1]), D, gap[k] / D, a.eps0 * op[k] / D, eb[k]])
    if not rows:
        sys.exit("no /networks/ptc_contacts in the frames of %s (does the stage write frames?)" % a.out)
    atomic_csv(a.prefix + "_openings.csv", ["frame", "id_a", "id_b", "D_m", "gap_over_D", "contact_strain_at_eps0", "break_strain"], rows)
    s = np.array([r[5] for r in rows]) * 100.0
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.hist(s, bins=80, density=True)
    ax.set_xlabel("contact strain eps0 delta / D at eps0 = %g %% [%%]" % (100 * a.eps0))
    ax.set_ylabel("probability density [1/%]")
    ax.set_title("%d touching contacts; median %.2g %%, %.1f %% negative" % (len(s), float(np.median(s)), 100.0 * float(np.mean(s < 0))))
    atomic_png(fig, a.prefix + "_openings.png")
    plt.close(fig)
    print("%d contacts: contact strain at eps0 = %g: mean %.3g %%, median %.3g %%, negative %.1f %%" %
          (len(s), a.eps0, float(np.mean(s)), float(np.median(s)), 100.0 * float(np.mean(s < 0))))


def cmd_heating(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = []
    fig, ax = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for out in a.outs:
        with open(os.path.join(out, "timeseries.csv")) as f:
            ts = list(csv.DictReader(f))
        label = os.path.basename(os.path.normpath(out))
        t = [num(r.get("physical_time", r.get("time"))) for r in ts]
        I = [num(r.get("electrical_current")) for r in ts]
        Tm = [num(r.get("heat_temperature_mean")) for r in ts]
        Tx = [num(r.get("heat_temperature_max")) for r in ts]
        for k, r in enumerate(ts):
            rows.append([label, r.get("stage", ""), t[k], I[k], num(r.get("electrical_resistance")), Tm[k], Tx[k],
                         num(r.get("ptc_self_heating_conducting"))])
        ax[0].plot(t, [abs(x) if math.isfinite(x) else float("nan") for x in I], label=label)
        ax[1].plot(t, Tm, label=label + " mean")
        ax[1].plot(t, Tx, ls=":", label=label + " max")
    ax[0].set_yscale("log")
    ax[0].set_ylabel("current [A]")
    ax[1].set_ylabel("temperature [K]")
    ax[1].set_xlabel("time [s]")
    ax[0].legend(fontsize=7)
    ax[1].legend(fontsize=7)
    atomic_csv(a.prefix + "_heating.csv", ["run", "stage", "time_s", "current_A", "resistance_Ohm", "T_mean_K", "T_max_K", "conducting_contacts"], rows)
    atomic_png(fig, a.prefix + "_heating.png")
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("strain")
    s.add_argument("out")
    s.add_argument("--prefix", required=True)
    o = sub.add_parser("openings")
    o.add_argument("out")
    o.add_argument("--prefix", required=True)
    o.add_argument("--eps0", type=float, default=0.01)
    h = sub.add_parser("heating")
    h.add_argument("outs", nargs="+")
    h.add_argument("--prefix", required=True)
    a = ap.parse_args()
    {"strain": cmd_strain, "openings": cmd_openings, "heating": cmd_heating}[a.cmd](a)


if __name__ == "__main__":
    main()
