#!/usr/bin/python3
"""Can the power-law creep branch reach the 30 MPa samples? (issue 36 item 4, a diagnostic, not a
validation.) For each packing seed, D_0 as calibrated on sample 2 by the ledger's
seed000/table1_densification run (grain-boundary law alone), samples 3 (1100 C, 30 MPa, measured
0.106) and 4 (1200 C, 30 MPa, 0.050) are hot pressed along their own cycles with the power-law
creep branch of the sintering law (n = 5.5, Q = 250 kJ/mol, sigma_0 100 MPa, T_ref 1200 C:
configs/materials/nial_sintering.json) at the reference strain rates RATES (eps_dot_0 [1/s]; the
review's order-of-magnitude anchor is ~5e-2 1/s), plus sample 4 at 1e2 1/s with the full-density
stop moved (creep_stop_gb_fraction 0 = none, 1.5, 2: the pair-wise necks overcount a particle's
grain boundary, seed 000 Eq. 24-25). A run whose output directory in --workdir already holds a
completed summary.json is read, not run again. One CSV row per run: the cooled envelope porosity (the ledger's
body), the mass porosity in the die after cooling and at the end of the hold, the envelope radius,
and which stop holds the necks at the end (stops()): the share of particles whose grain-boundary
fraction sum a^2 / (4 r^2) reached 1 (seed 000 Eq. 22-23, the law's creep_stop_gb_fraction), and
the shares of the necks frozen by it and by the overlap limit h >= r_min (creep_overlap_limit).

With --quasi-static the hot presses run on the inertia-free path (predict.to_quasi_static) and D_0
comes from the ledger's seed000/table1_densification_quasi_static run (RUNS_QS).

    python3 -m benchmarks.sps_table1.creep_scan --sparkdem build/sparkdem --workdir DIR [--jobs 2]
        [--runs benchmarks/validation/runs/full/seed000_table1_densification/N300.json]
        [--csv benchmarks/sps_table1/creep_scan.csv] [--quasi-static]
"""
import argparse
import json
import os
import subprocess
from concurrent import futures

import numpy as np

from benchmarks.perf.harness import write_csv_atomic
from benchmarks.sps_table1 import predict

RATES = (1e-2, 1.0, 1e2, 1e4)
MEASURED = predict.MEASURED
RUNS = os.path.join(predict.REPO, "benchmarks/validation/runs/full/seed000_table1_densification/N300.json")
RUNS_QS = os.path.join(predict.REPO, "benchmarks/validation/runs/full/seed000_table1_densification_quasi_static/N300.json")


def calibrated_d0(path):
    """{seed: D_0} of the ledger's table1 run file."""
    with open(path) as f:
        runs = json.load(f)
    out = {}
    for r in runs["runs"]:
        figs = r["figures"]
        out[r["seed"]] = next(v["extra"]["d0_calibrated_m2_s"] for v in figs.values())
    return out


def stops(out, limit=1.0):
    """Which creep stop holds the necks of a run's final state (out/final_state.h5): {particles_gb_full,
    necks_stopped_gb, necks_stopped_overlap} (shares)."""
    import h5py
    with h5py.File(os.path.join(out, "final_state.h5"), "r") as f:
        cols = f["state/contacts/state_columns"][()].decode().split()
        a = f["state/contacts/state"][:, cols.index("neck_radius")]
        i, j, h = f["state/contacts/i"][:], f["state/contacts/j"][:], f["state/contacts/overlap"][:]
        r = f["state/particles/radius"][:]
    neck = a > 0
    fgb = np.zeros(len(r))
    np.add.at(fgb, i[neck], a[neck] ** 2 / (4 * r[i[neck]] ** 2))
    np.add.at(fgb, j[neck], a[neck] ** 2 / (4 * r[j[neck]] ** 2))
    full = fgb >= limit
    n = max(1, int(neck.sum()))
    return {"particles_gb_full": float(full.mean()), "necks_stopped_gb": float((neck & (full[i] | full[j])).sum() / n),
            "necks_stopped_overlap": float((neck & (h >= np.minimum(r[i], r[j]))).sum() / n)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--runs", default=None, help="the ledger's run file with the calibrated D_0 (default RUNS, or RUNS_QS)")
    ap.add_argument("--quasi-static", action="store_true")
    ap.add_argument("--csv", default=os.path.join(predict.HERE, "creep_scan.csv"))
    a = ap.parse_args()
    a.runs = a.runs or (RUNS_QS if a.quasi_static else RUNS)
    prepare = predict.preparer(a.quasi_static)
    os.makedirs(a.workdir, exist_ok=True)
    version = subprocess.run([a.sparkdem, "--version"], capture_output=True, text=True).stdout.strip()
    items = []
    for seed, d0 in sorted(calibrated_d0(a.runs).items()):
        for k in (3, 4):
            for rate in RATES:
                items.append((seed, d0, k, rate, "full-density stop (creep_stop_gb_fraction 1)", {}))
        for stop in (0.0, 1.5, 2.0):
            items.append((seed, d0, 4, 1e2, f"creep_stop_gb_fraction {stop:g}" + (" (no full-density stop)" if stop == 0 else ""),
                          {"creep_stop_gb_fraction": stop}))

    def run(item):
        seed, d0, k, rate, variant, extra = item
        stop = extra.get("creep_stop_gb_fraction")
        name = f"seed{seed}_sample{k}_rate{rate:g}" + ("" if stop is None else "_nostop" if stop == 0 else f"_stop{stop:g}")
        out = os.path.join(a.workdir, name + "_out")
        p = predict.porosities(out) if os.path.exists(os.path.join(out, "summary.json")) else None  # a finished run is read
        if p is None:
            out = predict.run_scene(a.sparkdem, a.workdir, prepare(predict.scene(k, seed, d0, powerlaw_creep_rate=rate, **extra)), name)
            p = predict.porosities(out)
        return item, dict(p, **stops(out)) if p else None

    with futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(run, items))
    fields = ["seed", "sample", "measured", "d0_m2_s", "powerlaw_creep_rate_per_s", "variant", "porosity_envelope",
              "porosity_envelope_minus_measured", "porosity_mass", "porosity_mass_hold_end", "envelope_radius_m", "particles_gb_full",
              "necks_stopped_gb", "necks_stopped_overlap", "binary"]
    rows = []
    for (seed, d0, k, rate, variant, _), p in results:
        row = {"seed": seed, "sample": k, "measured": MEASURED[k], "d0_m2_s": "%.6g" % d0, "powerlaw_creep_rate_per_s": "%g" % rate,
               "variant": variant, "binary": version}
        if p:
            row.update({f: "%.5g" % v for f, v in p.items()})
            row["porosity_envelope_minus_measured"] = "%+.4f" % (p["porosity_envelope"] - MEASURED[k])
        rows.append(row)
    write_csv_atomic(a.csv, rows, fields)
    print(open(a.csv).read())


if __name__ == "__main__":
    main()
