#!/usr/bin/python3
"""How the cylinder's resistance moves with the neighbour tolerance and the eccentric elements
(issue 19, step 1), on the final frame of runs of seed001/cylinder (or any cylinder packing with
the end sets), re-solving seed 001's transmission-surface network (Eqs. 2-5) outside the engine.

    /usr/bin/python3 benchmarks/resistance_cylinder/sensitivity.py [--csv OUT.csv] RUN_DIR [RUN_DIR ...]

The re-solve is checked first: at the run's own tolerance it must give the engine's R to 1e-6
(else the script stops), so every other row differs from the engine only by the varied choice.
Rows (per run):
  tol/r_mean      neighbours = pairs with gap <= tol * r_mean (the engine: touch_tolerance [m])
  e_face          eccentricity threshold of f = 2 (seed 001: 0.4)
  interior_f1     f = 1 for every element more than one mean diameter from the surface
  f1              f = 1 everywhere
Columns: mean neighbours, eccentric share (all / interior), R/R_th - 1, the core's kappa rho_e
(r < r_d - 4 r_mean, locate_error.ring_kappa_arrays; 1 = the continuum), the skin coefficient
c = (R/R_th - 1) / (r_mean / r_d) (Table III: 0.60 +- 0.03). R_th as the ledger:
rho (l_d - 2 r_mean) / (pi r_d^2). Geometry and rho: seed 001 (r_d = 1 mm, l_d = 5 mm, 304L).
"""
import argparse
import glob
import json
import os
import sys

import h5py
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from locate_error import ring_kappa_arrays  # noqa: E402  (run as a script, beside it)

RHO, RD, LD = 0.73e-6, 1e-3, 5e-3
S3, S5 = np.sqrt(3.0), np.sqrt(5.0)
# Platonic alpha(n) = face area / inradius^2 (physics/electrical/conductance_kernels.cpp).
N_TAB = np.array([4.0, 6.0, 8.0, 12.0, 20.0])
A_TAB = np.array([6 * S3, 4.0, 1.5 * S3, np.sqrt(25 + 10 * S5) / 4 * 400 / (250 + 110 * S5), 12 * S3 / (3 + S5) ** 2])


def alpha(n):
    n = np.clip(n, 3.0, 20.0)
    k = np.clip(np.searchsorted(N_TAB, n, side="right") - 1, 0, len(N_TAB) - 2)
    t = (n - N_TAB[k]) / (N_TAB[k + 1] - N_TAB[k])
    return A_TAB[k] + t * (A_TAB[k + 1] - A_TAB[k])


def load(run):
    run = run + "/out" if os.path.isdir(run + "/out") else run  # ledger runs keep their output in out/
    f = h5py.File(sorted(glob.glob(run + "/frames/*.h5"))[-1], "r")
    p = f["particles"]
    out = {k: p[k][:] for k in ("position", "radius", "set_end_high", "set_end_low")}
    out["radius"] = out["radius"].ravel()
    s = json.load(open(run + "/summary.json"))
    fin = [t for t in s["stages"] if "electrical_resistance" in t.get("final", {})][-1]["final"]
    resolved = json.load(open(run + "/resolved.json"))
    mods = [st["modules"]["electrical_network"] for st in resolved["stages"] if "electrical_network" in st.get("modules", {})]
    rel = mods[-1].get("touch_tolerance_relative", 0.0)
    out["R_engine"] = fin["electrical_resistance"]
    out["tol_m"] = rel * out["radius"].mean() if rel > 0 else mods[-1]["touch_tolerance"]
    return out


def network(x, r, tol_m):
    tree = cKDTree(x)
    pairs = tree.query_pairs(2.0 * r.max() + tol_m, output_type="ndarray")
    d = np.linalg.norm(x[pairs[:, 1]] - x[pairs[:, 0]], axis=1)
    keep = d - r[pairs[:, 0]] - r[pairs[:, 1]] <= tol_m
    return pairs[keep], d[keep]


def resistance(x, r, hi, lo, pairs, dist, e_face=0.4, f_mask=None):
    n_el = len(r)
    a, b = pairs[:, 0], pairs[:, 1]
    cnt = np.bincount(a, minlength=n_el) + np.bincount(b, minlength=n_el)
    cen = np.zeros_like(x)
    np.add.at(cen, a, x[b])
    np.add.at(cen, b, x[a])
    with np.errstate(invalid="ignore"):
        e = np.linalg.norm(cen / np.maximum(cnt, 1)[:, None] - x, axis=1) / r
    e[cnt == 0] = 0.0
    f = np.where(e >= e_face, 2.0, 1.0)
    if f_mask is not None:
        f[f_mask] = 1.0
    S = alpha(cnt) * r * r / f
    g = np.sqrt(S[a] * S[b]) / (RHO * dist)
    K = coo_matrix((np.concatenate([-g, -g, g, g]), (np.concatenate([a, b, a, b]), np.concatenate([b, a, a, b]))),
                   shape=(n_el, n_el)).tocsr()
    # Nodes outside every component holding an electrode carry no current (the engine drops them).
    _, comp = connected_components(K, directed=False)
    live = np.isin(comp, np.unique(comp[hi | lo]))
    fixed = hi | lo
    free = ~fixed & live
    u = np.where(hi, 1.0, 0.0)
    Kff = K[free][:, free]
    rhs = -K[free][:, fixed] @ u[fixed]
    u[free] = spsolve(Kff.tocsc(), rhs)
    current = (K @ u)[hi].sum()
    # The core's kappa rho_e (r < r_d - 4 r_mean; locate_error.ring_kappa_arrays) from the branch currents.
    kappa, _ = ring_kappa_arrays(x, np.where(live, u, np.nan), a, b, g * (u[a] - u[b]), [0.0, RD - 4.0 * r.mean(), 10.0 * RD])
    return 1.0 / current, cnt.mean(), (f > 1).mean(), e, kappa[0] * RHO


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--csv")
    a = ap.parse_args()
    rows = []
    for run in a.runs:
        d = load(run)
        x, r = d["position"], d["radius"]
        hi, lo = d["set_end_high"].ravel() > 0.5, d["set_end_low"].ravel() > 0.5
        rm = r.mean()
        r_th = RHO * (LD - 2.0 * rm) / (np.pi * RD ** 2)
        dsurf = np.minimum(RD - np.hypot(x[:, 0], x[:, 1]), np.minimum(x[:, 2] - x[:, 2].min() + r, x[:, 2].max() + r - x[:, 2]))
        interior = dsurf > 2.0 * rm
        pairs, dist = network(x, r, d["tol_m"])
        R0, *_ = resistance(x, r, hi, lo, pairs, dist)
        if abs(R0 / d["R_engine"] - 1.0) > 1e-6:
            sys.exit(f"{run}: re-solve gives R = {R0:.9g}, the engine {d['R_engine']:.9g}; the network differs")
        variants = [(f"tol/r_mean={t:g}", t * rm, 0.4, None) for t in (0.0, 0.005, 0.01, 0.02, 0.05, 0.1)]
        variants += [("engine tol, e_face=0.5", d["tol_m"], 0.5, None), ("engine tol, e_face=0.6", d["tol_m"], 0.6, None),
                     ("engine tol, interior_f1", d["tol_m"], 0.4, interior),
                     ("engine tol, f1", d["tol_m"], 0.4, np.ones(len(r), bool))]
        for name, tol, ef, mask in variants:
            pr, ds = network(x, r, tol)
            R, nmean, ecc, e, core = resistance(x, r, hi, lo, pr, ds, ef, mask)
            row = {"run": run, "N": len(r), "variant": name, "tol_over_r_mean": tol / rm, "mean_neighbours": nmean,
                   "eccentric_share": float((e >= ef).mean()), "eccentric_share_interior": float((e[interior] >= ef).mean()),
                   "interior_share": float(interior.mean()), "R_over_R_th_minus_1_pct": 100 * (R / r_th - 1),
                   "core_kappa_rho": core, "skin_c": (R / r_th - 1) / (rm / RD)}
            rows.append(row)
            print(f"{run.split('/')[-1]:>14} {name:>28}  n {nmean:5.2f}  ecc {100 * row['eccentric_share']:5.1f} % "
                  f"(interior {100 * row['eccentric_share_interior']:5.1f} %)  R/R_th-1 {row['R_over_R_th_minus_1_pct']:+6.2f} %"
                  f"  core kappa rho {core:.4f}  c {row['skin_c']:.2f}")
    if a.csv:
        import csv
        with open(a.csv + ".tmp", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        os.replace(a.csv + ".tmp", a.csv)


if __name__ == "__main__":
    main()
