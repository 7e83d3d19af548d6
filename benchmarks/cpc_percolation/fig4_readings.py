#!/usr/bin/python3
"""Seed 002 Fig. 4: which points does the paper's strain histogram cover? (issue 39 item 1)

The RKPM grid covers the whole box, so the solved field u(x) exists inside the rigid fillers too.
Fig. 4 ("distribution function of the maximum principal strain", eps0 = 1 %) may be a histogram
over (a) the matrix only, (b) every point of the box, filler interiors included, or (c) the grid
nodes unweighted. This study solves the primary scenes of configs/cpc_ptc_rkpm.json (free
expansion, alpha R / E = 100, nu = 0.35, h = 3 R, L = 70 R; make_rkpm_configs.stage) at
phi = 25 % and 8.5 %, lambda = 0 and 35 R, once per reading (ptc_strain `strain_points` matrix /
box / nodes; the solve is the same, only the sampled points differ), adds the derived reading
box_rigid (the matrix histogram with the fillers' volume share at exactly zero, their rigid strain;
no solve), and reports per run the features Fig. 4 and its text give, at eps0 = 1 %:

  peak_pct           the bin of largest weight of the total max principal strain [% strain]
                     (paper: 0.03-0.05 % at phi = 25 %)
  negative_weight    weight below zero (paper: about 16 % and 10 % at phi = 25 %)
  mean_pct           weighted mean [%] (paper, text: mean local strain 0.44 / 0.60 eps0 at 2.5 %)
  skewness           of the histogram (paper: at 8.5 % "broadened and skewed toward positive")
  plateau_weight     weight in [0.5, 1) % (paper: the segregated dispersion's plateau at 8.5 %)
  outside_edges      weight outside the histogram's -1.2 .. 1.5 % (left out of peak, skewness, plateau)

The reading is decided from these shape features only, before any switching strain of a new
variant is looked at (issue 39); the decision is recorded in rkpm_results.md.

    python3 -m benchmarks.cpc_percolation.fig4_readings --sparkdem BIN --workdir DIR
        [--seeds 1,2] [--phis 0.25,0.085] [--lambdas 0,35] [--readings matrix,box,nodes]
        [--box 70] [--reuse] [--csv benchmarks/cpc_percolation/fig4_readings.csv]
"""
import concurrent.futures
import csv
import math
import os

from benchmarks.cpc_percolation.make_rkpm_configs import STRAIN_EDGES, stage
from benchmarks.perf.harness import run_study_scene, study_parser, write_csv_atomic
from tools.plot_cpc import scenario

PLATEAU = (0.005, 0.01)  # [1] strain window of the segregated plateau at phi = 8.5 %


def scene(phi, lam, reading, seeds, box=70.0):
    name = f"L{box:g}_lambda{lam:g}_phi{phi:g}_{reading}"
    st = stage(name, float(lam), seeds, box=box, strain_points=reading)
    st["generator"]["volume_fraction"] = phi
    return name, scenario("fig4_readings", "seed 002 Fig. 4 readings (benchmarks/cpc_percolation/fig4_readings.py)", [st])


def features(row, rigid_share=0.0):
    """The shape features of one configuration's total-strain histogram (0.01 % bins). With
    rigid_share > 0 (the derived reading "box_rigid"): the matrix histogram weighted by
    1 - rigid_share plus rigid_share at exactly zero strain, the fillers' own (rigid) strain."""
    keep = 1.0 - rigid_share
    w = [keep * float(row[f"ptc_strain_strain_total_hist_{k:02d}"]) for k in range(len(STRAIN_EDGES) - 1)]
    mid = [0.5 * (a + b) for a, b in zip(STRAIN_EDGES[:-1], STRAIN_EDGES[1:])]
    w[STRAIN_EDGES.index(0.0)] += rigid_share
    mid[STRAIN_EDGES.index(0.0)] = 0.0
    inside = sum(w)
    mean = sum(x * v for x, v in zip(mid, w)) / inside
    var = sum((x - mean) ** 2 * v for x, v in zip(mid, w)) / inside
    skew = sum((x - mean) ** 3 * v for x, v in zip(mid, w)) / inside / var ** 1.5 if var > 0 else math.nan
    k = max(range(len(w)), key=lambda i: w[i])
    return {"peak_pct": 100 * mid[k], "negative_weight": keep * float(row["ptc_strain_strain_total_negative_fraction"]),
            "mean_pct": 100 * keep * float(row["ptc_strain_strain_total_mean"]), "skewness": skew,
            "plateau_weight": sum(v for x, v in zip(mid, w) if PLATEAU[0] <= x < PLATEAU[1]),
            "outside_edges": keep * (float(row["ptc_strain_strain_total_hist_below"]) + float(row["ptc_strain_strain_total_hist_above"]))}


def run(sparkdem, workdir, phi, lam, reading, seeds, box, reuse):
    name, sc = scene(phi, lam, reading, seeds, box)
    out, s = run_study_scene(sparkdem, workdir, name, sc, reuse=reuse)
    with open(os.path.join(out, f"sweep_{name}.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    out = [dict(phi=phi, lambda_R=lam, reading=reading, config=i + 1, particles=int(float(r["packing.particles"])),
                **features(r)) for i, r in enumerate(rows)]
    if reading == "matrix":  # derived, no solve: the fillers at their rigid strain 0 (share: the packing's phi)
        out += [dict(phi=phi, lambda_R=lam, reading="box_rigid", config=i + 1, particles=int(float(r["packing.particles"])),
                     **features(r, float(r["packing.volume_fraction"]))) for i, r in enumerate(rows)]
    return out


def main():
    ap = study_parser(__doc__, "", "benchmarks/cpc_percolation/fig4_readings.csv", seeds_default="1,2")
    ap.add_argument("--phis", default="0.25,0.085")
    ap.add_argument("--lambdas", default="0,35")
    ap.add_argument("--readings", default="matrix,box,nodes")
    ap.add_argument("--box", type=float, default=70.0, help="box edge in filler radii (70: the paper's)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="keep finished runs of an identical scene")
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    seeds = [int(s) for s in a.seeds.split(",")]
    jobs = [(float(p), float(l), r) for p in a.phis.split(",") for l in a.lambdas.split(",") for r in a.readings.split(",")]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        parts = list(ex.map(lambda j: run(os.path.abspath(a.sparkdem), a.workdir, *j, seeds, a.box, a.reuse), jobs))
    rows = [r for p in parts for r in p]
    write_csv_atomic(a.csv, rows)
    keys = ("peak_pct", "negative_weight", "mean_pct", "skewness", "plateau_weight")
    for (phi, lam, reading) in jobs + [(p, l, "box_rigid") for (p, l, r) in jobs if r == "matrix"]:
        sel = [r for r in rows if (r["phi"], r["lambda_R"], r["reading"]) == (phi, lam, reading)]
        print(f"phi {phi:g} lambda {lam:g} {reading:7s} " + " ".join(
            f"{k} {sum(r[k] for r in sel) / len(sel):.4g}" for k in keys))


if __name__ == "__main__":
    main()
