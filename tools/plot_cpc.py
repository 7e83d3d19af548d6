#!/usr/bin/env python3
"""Percolation of seed-002 filler configurations (cpc_fillers + contact_percolation).

  plot_cpc.py config --out configs/cpc_percolation.json [--box 70] [--lambda 0] [--seeds 10]
                     [--phis 0.15,0.17,...] [--name cpc_percolation]
      writes a scenario: one cpc_fillers stage per volume fraction, each a seeds sweep
      (ensemble) evaluated by electrical_network (touching, unit conductances) and
      contact_percolation (touch tolerance 0.1 % of D).

  plot_cpc.py analyse OUT [OUT ...] --prefix PREFIX [--tmin 0.01 --tmax 0.12]
      reads OUT/summary.json and OUT/sweep_<stage>.csv of such runs, groups the stages by
      (box length L, lambda), and writes
        PREFIX_points.csv  per (L, lambda, phi): configurations, spanning probability P and its
                           binomial error, mean conductivity sigma = 1/rho (0 when not spanning),
                           mean coordination Z, mean largest-cluster fraction, paper-mean rho
        PREFIX_fits.csv    per (L, lambda): phi_c and width w of the sigmoid
                           P = 1 / (1 + exp(-(phi - phi_c) / w)) (least squares, binomial
                           weights, standard errors from the covariance), and the exponent t of
                           Delta sigma = sigma(phi) - sigma(phi_c) = A (phi - phi_c)^t (linear fit
                           of log Delta sigma on log(phi - phi_c) for tmin <= phi - phi_c <= tmax)
        PREFIX.png         P(phi) with the sigmoids, and Delta sigma against phi - phi_c (log-log)
python3 stdlib + matplotlib only.
"""
import argparse
import csv
import json
import math
import os
import sys

COLLECT = ["contact_percolation_spanning", "contact_percolation_spanning_clusters",
           "contact_percolation_largest_cluster_fraction", "contact_percolation_coordination",
           "contact_percolation_resistivity", "contact_percolation_conductivity",
           "contact_percolation_resistivity_cluster_mean", "packing.volume_fraction", "packing.particles",
           "packing.generation_wall_time_s"]


def scenario(name, description, stages):
    """The scenario around cpc_fillers stages: a filler material, an inert contact law (the stages
    freeze the mechanics) and the electrode sets on the faces x = 0 and x = L."""
    return {"name": name, "description": description, "seed": 1,
            "materials": [{"name": "filler", "density": 1000}],
            "contact": {"law": "hertz_mindlin",
                        "params": {"youngs_modulus": 1e6, "poisson_ratio": 0.3, "restitution": 0.5, "friction": 0.0}},
            "particle_sets": {"x_lo": {"type": "touching_wall", "wall": "xlo", "tolerance": 0.0},
                              "x_hi": {"type": "touching_wall", "wall": "xhi", "tolerance": 0.0}},
            "stages": stages}


def make_config(a):
    phis = [float(x) for x in a.phis.split(",")]
    seeds = list(range(1, a.seeds + 1))
    R = 1.0
    tol = 2e-3 * R  # 0.1 % of D
    stages = []
    for phi in phis:
        stages.append({
            "name": "L%g_lambda%g_phi%.4f" % (a.box, a.lam, phi),
            "type": "cpc_fillers",
            "generator": {"radius": R, "box_length": a.box, "volume_fraction": phi, "aggregation_lambda": a.lam},
            "dt": 1.0, "stop": {"steps": 0}, "sets": ["x_lo", "x_hi"],
            "modules": {
                "electrical_network": {"model": "touching", "high": "x_lo", "low": "x_hi", "unit_conductance": 1.0,
                                       "touch_tolerance": tol, "solver": "direct", "empty_electrode": "open"},
                "contact_percolation": {"high": "x_lo", "low": "x_hi", "touch_gap_rel": tol / (2 * R),
                                        "cluster_resistances": True}},
            "sweep": {"seeds": seeds, "collect": COLLECT}})
    cfg = scenario(a.name,
                   "Seed 002 (Barbieri et al.) percolation of rigid monodisperse fillers: cpc_fillers configurations "
                   "(contact algorithm gamma = 0.4, largest relative overlap <= 1e-3, open box; aggregation lambda = %g R) "
                   "in a cube of L = %g R, %d configurations (seeds) per volume fraction; electrodes = spheres reaching "
                   "the faces x = 0 and x = L; touching = gap <= 0.1 %% of D; unit conductances; rho = R_eq L. "
                   "Analyse with tools/plot_cpc.py analyse OUT. Written by tools/plot_cpc.py config."
                   % (a.lam, a.box, a.seeds), stages)
    # Compact layout: one line per key of the top level and of each stage.
    lines = ["{"]
    top = [(k, v) for k, v in cfg.items() if k != "stages"]
    for k, v in top:
        lines.append("  %s: %s," % (json.dumps(k), json.dumps(v)))
    lines.append('  "stages": [')
    for n, st in enumerate(cfg["stages"]):
        body = ",\n     ".join("%s: %s" % (json.dumps(k), json.dumps(v)) for k, v in st.items())
        lines.append("    {" + body + "}" + ("," if n + 1 < len(cfg["stages"]) else ""))
    lines.append("  ]")
    lines.append("}")
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")


def num(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return float("nan")
    return v


def read_runs(outs):
    """Per (L, lambda): {phi: [rows]} from the sweep tables of every run directory."""
    groups = {}
    for out in outs:
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        with open(os.path.join(out, "resolved.json")) as f:
            resolved = json.load(f)
        gens = {st["name"]: st.get("generator", {}) for st in resolved["stages"]}
        for st in summary["stages"]:
            if "sweep" not in st:
                continue
            g = gens[st["name"]]
            key = (float(g["box_length"]) / float(g["radius"]), float(g["aggregation_lambda"]))
            with open(os.path.join(out, st["sweep"]["table"])) as f:
                rows = [r for r in csv.DictReader(f) if r["status"] == "completed"]
            groups.setdefault(key, {}).setdefault(float(g["volume_fraction"]), []).extend(rows)
    return groups


def mean(xs):
    xs = [x for x in xs if math.isfinite(x)]
    return sum(xs) / len(xs) if xs else float("nan")


def sigmoid(phi, pc, w):
    z = -(phi - pc) / w
    return 1.0 / (1.0 + math.exp(z)) if z < 700 else 0.0


def fit_sigmoid(points):
    """Weighted least squares of P = 1/(1 + exp(-(phi - pc)/w)); weights 1/var with the binomial
    variance P(1-P)/n regularised by (n + 1) (no infinite weights at P = 0 or 1). Gauss-Newton with
    step halving; returns pc, w and their standard errors."""
    xs = [p["phi"] for p in points]
    ys = [p["P"] for p in points]
    ws = [p["n"] / max((p["P"] * (1 - p["P"])), 0.25 / (p["n"] + 1)) for p in points]
    # Start: phi where P crosses 1/2 (linear interpolation), width from the span of the data.
    pc = xs[min(range(len(xs)), key=lambda k: abs(ys[k] - 0.5))]
    w = (max(xs) - min(xs)) / 10.0

    def cost(pc, w):
        return sum(wk * (sigmoid(x, pc, w) - y) ** 2 for x, y, wk in zip(xs, ys, ws))

    c = cost(pc, w)
    for _ in range(200):
        # Jacobian of the model in (pc, w).
        JTJ = [[0.0, 0.0], [0.0, 0.0]]
        JTr = [0.0, 0.0]
        for x, y, wk in zip(xs, ys, ws):
            s = sigmoid(x, pc, w)
            ds = s * (1 - s)
            j = [-ds / w, -ds * (x - pc) / (w * w)]
            r = y - s
            for a in range(2):
                JTr[a] += wk * j[a] * r
                for b in range(2):
                    JTJ[a][b] += wk * j[a] * j[b]
        det = JTJ[0][0] * JTJ[1][1] - JTJ[0][1] * JTJ[1][0]
        if det == 0:
            break
        d = [(JTJ[1][1] * JTr[0] - JTJ[0][1] * JTr[1]) / det, (JTJ[0][0] * JTr[1] - JTJ[1][0] * JTr[0]) / det]
        step = 1.0
        while step > 1e-6:
            npc, nw = pc + step * d[0], w + step * d[1]
            if nw > 0 and cost(npc, nw) <= c:
                break
            step *= 0.5
        if step <= 1e-6:
            break
        npc, nw = pc + step * d[0], w + step * d[1]
        nc = cost(npc, nw)
        done = abs(c - nc) <= 1e-14 * max(c, 1e-300)
        pc, w, c = npc, nw, nc
        if done:
            break
    # Covariance: inverse of J^T W J (binomial weights are absolute variances), scaled by the
    # reduced chi^2 when that exceeds 1 (scatter beyond the binomial noise).
    JTJ = [[0.0, 0.0], [0.0, 0.0]]
    for x, wk in zip(xs, ws):
        s = sigmoid(x, pc, w)
        ds = s * (1 - s)
        j = [-ds / w, -ds * (x - pc) / (w * w)]
        for a in range(2):
            for b in range(2):
                JTJ[a][b] += wk * j[a] * j[b]
    det = JTJ[0][0] * JTJ[1][1] - JTJ[0][1] * JTJ[1][0]
    dof = max(len(xs) - 2, 1)
    scale = max(c / dof, 1.0)
    epc = math.sqrt(scale * JTJ[1][1] / det) if det > 0 else float("nan")
    ew = math.sqrt(scale * JTJ[0][0] / det) if det > 0 else float("nan")
    return pc, w, epc, ew


def fit_power(points, pc, tmin, tmax=float("inf")):
    """t of Delta sigma = sigma - sigma(pc) = A (phi - pc)^t: least squares line of log Delta sigma
    on log(phi - pc) over the points with tmin <= phi - pc <= tmax and Delta sigma > 0. sigma(pc) is the
    linear interpolation of the mean sigma between the two points around pc (0 below the data)."""
    pts = sorted(points, key=lambda p: p["phi"])
    s_pc = 0.0
    for a, b in zip(pts, pts[1:]):
        if a["phi"] <= pc <= b["phi"]:
            s_pc = a["sigma"] + (b["sigma"] - a["sigma"]) * (pc - a["phi"]) / (b["phi"] - a["phi"])
    xy = [(math.log(p["phi"] - pc), math.log(p["sigma"] - s_pc)) for p in pts
          if tmin <= p["phi"] - pc <= tmax and p["sigma"] - s_pc > 0]
    if len(xy) < 2:
        return float("nan"), float("nan"), len(xy), s_pc
    n = len(xy)
    mx = sum(x for x, _ in xy) / n
    my = sum(y for _, y in xy) / n
    sxx = sum((x - mx) ** 2 for x, _ in xy)
    t = sum((x - mx) * (y - my) for x, y in xy) / sxx
    res = sum((y - my - t * (x - mx)) ** 2 for x, y in xy)
    et = math.sqrt(res / (n - 2) / sxx) if n > 2 else float("nan")
    return t, et, n, s_pc


def analyse(a):
    groups = read_runs(a.outs)
    point_rows, fit_rows, curves = [], [], []
    for (L, lam), byphi in sorted(groups.items()):
        points = []
        for phi, rows in sorted(byphi.items()):
            sp = [num(r["contact_percolation_spanning"]) for r in rows]
            n = len(sp)
            P = sum(sp) / n
            sig = [num(r["contact_percolation_conductivity"]) for r in rows]
            p = {"L": L, "lambda": lam, "phi": phi, "n": n, "P": P, "P_err": math.sqrt(max(P * (1 - P), 0.0) / n),
                 "sigma": mean(sig),
                 "sigma_std": math.sqrt(mean([(s - mean(sig)) ** 2 for s in sig])) if n > 1 else float("nan"),
                 "Z": mean([num(r["contact_percolation_coordination"]) for r in rows]),
                 "largest_cluster": mean([num(r["contact_percolation_largest_cluster_fraction"]) for r in rows]),
                 "rho_cluster_mean": mean([num(r["contact_percolation_resistivity_cluster_mean"]) for r in rows]),
                 "phi_actual": mean([num(r["packing.volume_fraction"]) for r in rows]),
                 "generation_s": mean([num(r.get("packing.generation_wall_time_s")) for r in rows])}
            points.append(p)
            point_rows.append(p)
        pc, w, epc, ew = fit_sigmoid(points)
        t, et, nt, s_pc = fit_power(points, pc, a.tmin, a.tmax)
        fit_rows.append({"L": L, "lambda": lam, "configurations": sum(p["n"] for p in points), "phi_points": len(points),
                         "phi_c": pc, "phi_c_err": epc, "width": w, "width_err": ew, "t": t, "t_err": et,
                         "t_points": nt, "sigma_at_phi_c": s_pc})
        curves.append((L, lam, points, pc, w, s_pc))
    with open(a.prefix + "_points.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(point_rows[0].keys()))
        wr.writeheader()
        wr.writerows(point_rows)
    with open(a.prefix + "_fits.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(fit_rows[0].keys()))
        wr.writeheader()
        wr.writerows(fit_rows)
    for r in fit_rows:
        print("L = %g R, lambda = %g: %d configurations over %d phi; phi_c = %.4f +- %.4f, w = %.4f; t = %.3f +- %.3f (%d points)"
              % (r["L"], r["lambda"], r["configurations"], r["phi_points"], r["phi_c"], r["phi_c_err"], r["width"],
                 r["t"], r["t_err"], r["t_points"]))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not available: no PNG", file=sys.stderr)
        return
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    for L, lam, points, pc, w, s_pc in curves:
        lab = "L = %g R, lambda = %g" % (L, lam)
        xs = [p["phi"] for p in points]
        l, = ax[0].plot(xs, [p["P"] for p in points], "o", label=lab + " (phi_c = %.3f)" % pc)
        ax[0].errorbar(xs, [p["P"] for p in points], yerr=[p["P_err"] for p in points], fmt="none", color=l.get_color())
        fine = [min(xs) + (max(xs) - min(xs)) * k / 200 for k in range(201)]
        ax[0].plot(fine, [sigmoid(x, pc, w) for x in fine], "-", color=l.get_color())
        dd = [(p["phi"] - pc, p["sigma"] - s_pc) for p in points if p["phi"] > pc and p["sigma"] - s_pc > 0]
        if dd:
            ax[1].loglog([d[0] for d in dd], [d[1] for d in dd], "o-", color=l.get_color(), label=lab)
    ax[0].set_xlabel("volume fraction phi")
    ax[0].set_ylabel("spanning probability P")
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel("phi - phi_c")
    ax[1].set_ylabel("sigma - sigma(phi_c)  [unit conductance / R]")
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.prefix + ".png", dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("config")
    c.add_argument("--out", required=True)
    c.add_argument("--name", default="cpc_percolation")
    c.add_argument("--box", type=float, default=70.0, help="L in units of R")
    c.add_argument("--lam", "--lambda", dest="lam", type=float, default=0.0)
    c.add_argument("--seeds", type=int, default=10)
    c.add_argument("--phis", default="0.16,0.18,0.20,0.21,0.22,0.23,0.24,0.25,0.26,0.28,0.31,0.35")
    n = sub.add_parser("analyse")
    n.add_argument("outs", nargs="+")
    n.add_argument("--prefix", required=True)
    # The fit range [0.01, 0.12] is issue 22's, adopted as the default in stop 30 (before: >= 0.005;
    # the values for >= 0.005 and >= 0.02 had been seen, the [0.01, 0.12] value had not).
    n.add_argument("--tmin", type=float, default=0.01, help="smallest phi - phi_c in the power-law fit")
    n.add_argument("--tmax", type=float, default=0.12, help="largest phi - phi_c in the power-law fit")
    a = ap.parse_args()
    if a.cmd == "config":
        make_config(a)
    else:
        analyse(a)


if __name__ == "__main__":
    main()
