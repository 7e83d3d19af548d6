#!/usr/bin/python3
"""Issue 58: why the pin's torsion stiffness drifts with N (seed001/torsion_contact_stiffness).

Reads the ledger's full-tier runs of seed001/torsion_contact (their run directories, as
`tools.validate run --tier full --case seed001/torsion_contact` leaves them, and the stiffness
each record holds) and measures on each packing what the beams are: beams per element, the mean
bond degree of the elements within one mean diameter of the pin's surface and of the rest, and
the beams' initial overlap (r_i + r_j - L0) over the mean radius, and the pack stage's own
coordination (mean, and of its interior: elements 4 mean diameters from every wall) with the
interior's share of the elements (summary.json). Then fits the stiffness ratio
over all runs to a + b * (beams per element), and reports the fit and each N's mean residual.

    /usr/bin/python3 -m benchmarks.torsion_crack.stiffness_coordination
        [--runs build/validation/full/seed001_torsion_contact]
        [--csv benchmarks/torsion_crack/stiffness_coordination.csv]
"""
import argparse
import json
import os

import h5py
import numpy as np

from benchmarks.perf.harness import write_csv_atomic

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LEDGER_RUNS = os.path.join(REPO, "benchmarks/validation/runs/full/seed001_torsion_contact")
PIN_RADIUS_M = 1e-3


def packing_row(rundir):
    """Beams and their geometry in a torsion run's final state (every bond, broken or not, is
    one made at the start of the twist; the frame after the pack stage gives the positions)."""
    with h5py.File(os.path.join(rundir, "out/final_state.h5")) as f:
        radius = np.array(f["state/particles/radius"])
        bi, bj = np.array(f["state/bonds/i"]), np.array(f["state/bonds/j"])
        length0 = np.array(f["state/bonds/reference"])[:, 0]
    with h5py.File(os.path.join(rundir, "out/frames/frame_000000.h5")) as f:
        x = np.array(f["particles/position"])
    with open(os.path.join(rundir, "out/summary.json")) as f:
        packing = next(st for st in json.load(f)["stages"] if st["name"] == "pack")["packing"]
    n, r_mean = len(radius), radius.mean()
    degree = np.bincount(bi, minlength=n) + np.bincount(bj, minlength=n)
    skin = np.hypot(x[:, 0], x[:, 1]) > PIN_RADIUS_M - 2.0 * r_mean
    overlap = (radius[bi] + radius[bj] - length0) / r_mean
    return {"beams_per_element": len(bi) / n, "degree_skin": degree[skin].mean(),
            "degree_inside": degree[~skin].mean(), "overlap_mean_over_r_mean": overlap.mean(),
            "r_mean_over_pin_radius": r_mean / PIN_RADIUS_M,
            "packing_coordination_mean": packing["coordination_mean"],
            "packing_coordination_interior": packing["coordination_interior"],
            "packing_interior_share": packing["interior_share"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", default=os.path.join(REPO, "build/validation/full/seed001_torsion_contact"))
    ap.add_argument("--csv", default=os.path.join(REPO, "benchmarks/torsion_crack/stiffness_coordination.csv"))
    a = ap.parse_args()
    rows = []
    for name in sorted(os.listdir(LEDGER_RUNS)):
        with open(os.path.join(LEDGER_RUNS, name)) as f:
            record = json.load(f)
        for run in record["runs"]:
            rundir = os.path.join(a.runs, f"N{record['N']}_seed{run['seed']}")
            rows.append(dict(N=record["N"], seed=run["seed"], commit=record["commit"],
                             stiffness_ratio=run["figures"]["stiffness"]["measured"], **packing_row(rundir)))
    rows.sort(key=lambda r: (r["N"], r["seed"]))
    z = np.array([r["beams_per_element"] for r in rows])
    k = np.array([r["stiffness_ratio"] for r in rows])
    (a0, b), *_ = np.linalg.lstsq(np.vstack([np.ones_like(z), z]).T, k, rcond=None)
    resid = k - (a0 + b * z)
    for r, e in zip(rows, resid):
        r["fit_residual"] = e
    write_csv_atomic(a.csv, rows)
    r2 = 1.0 - (resid ** 2).sum() / ((k - k.mean()) ** 2).sum()
    print(f"stiffness ratio = {a0:.3f} + {b:.3f} * beams per element over {len(rows)} runs: R^2 = {r2:.3f}, "
          f"residual rms {resid.std():.4f}; d ln k / d ln z = {b * z.mean() / k.mean():.2f}")
    for n in sorted({r["N"] for r in rows}):
        m = np.array([r["N"] == n for r in rows])
        sk = np.array([r["degree_skin"] for r in rows])[m]
        ins = np.array([r["degree_inside"] for r in rows])[m]
        col = lambda key: np.mean([r[key] for r, keep in zip(rows, m) if keep])
        print(f"N={n}: beams/element {z[m].mean():.3f} +- {z[m].std(ddof=1):.3f}, degree skin {sk.mean():.2f} "
              f"inside {ins.mean():.2f}; packing coordination {col('packing_coordination_mean'):.2f}, interior "
              f"{col('packing_coordination_interior'):.2f} on {col('packing_interior_share'):.2f} of the elements; stiffness {k[m].mean():.4f}, fit {k[m].mean() - resid[m].mean():.4f}, "
              f"mean residual {resid[m].mean():+.4f}")


if __name__ == "__main__":
    main()
