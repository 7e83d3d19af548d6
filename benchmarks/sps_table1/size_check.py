#!/usr/bin/python3
"""Does the Table 1 porosity depend on the compact's size? (issue 36 item 4: the ledger's figures
come from a ~300-particle compact; the porosity at N and 4N should agree within 0.005.) For each
packing seed, with D_0 as calibrated on sample 2 by the ledger's seed000/table1_densification
run, every sample is hot pressed along its cycle twice: the shipped compact (die radius 15.8 um,
bed 54.2 um at the generator's solid fraction: ~300 particles) and one with the die radius and
the bed length scaled by 4^(1/3) (~1200 particles, the same aspect ratio). One CSV row per run:
seed, sample, scale, particles, cooled envelope porosity (the ledger's body), mass porosity in the
die cooled and at the end of the hold; then per (seed, sample) the difference 4N - N.

With --quasi-static the hot presses run on the inertia-free path (predict.to_quasi_static), D_0 from
the ledger's seed000/table1_densification_quasi_static run.

    python3 -m benchmarks.sps_table1.size_check --sparkdem build/sparkdem --workdir DIR [--jobs 2]
        [--samples 2 4] [--runs RUNFILE] [--csv benchmarks/sps_table1/size_check.csv] [--quasi-static]
"""
import argparse
import json
import os
import subprocess
from concurrent import futures

from benchmarks.perf.harness import write_csv_atomic
from benchmarks.sps_table1 import predict
from benchmarks.sps_table1.creep_scan import RUNS, RUNS_QS, calibrated_d0

SCALE = 4.0 ** (1.0 / 3.0)


def scaled(sc, factor):
    """The scene with its packing generator's die radius and bed length scaled by `factor`."""
    gen = next(s for s in sc["stages"] if s["name"] == "pack")["generator"]
    gen["radius"] *= factor
    gen["length"] *= factor
    return sc


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--samples", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--runs", default=None, help="the ledger's run file with the calibrated D_0 (default RUNS, or RUNS_QS)")
    ap.add_argument("--quasi-static", action="store_true")
    ap.add_argument("--csv", default=os.path.join(predict.HERE, "size_check.csv"))
    a = ap.parse_args()
    a.runs = a.runs or (RUNS_QS if a.quasi_static else RUNS)
    prepare = predict.preparer(a.quasi_static)
    os.makedirs(a.workdir, exist_ok=True)
    version = subprocess.run([a.sparkdem, "--version"], capture_output=True, text=True).stdout.strip()
    items = [(seed, d0, k, f) for seed, d0 in sorted(calibrated_d0(a.runs).items()) for k in a.samples for f in (SCALE, 1.0)]

    def run(item):
        seed, d0, k, f = item
        out = predict.run_scene(a.sparkdem, a.workdir, prepare(scaled(predict.scene(k, seed, d0), f)), f"seed{seed}_sample{k}_{'4N' if f > 1 else 'N'}")
        p = predict.porosities(out)
        n = None
        if p:
            with open(os.path.join(out, "summary.json")) as fh:
                n = json.load(fh)["stages"][-1].get("particles")
        return item, p, n

    with futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(run, items))
    fields = ["seed", "sample", "measured", "d0_m2_s", "size", "particles", "porosity_envelope", "porosity_mass",
              "porosity_mass_hold_end", "envelope_4N_minus_N", "binary"]
    by = {(s, k, f > 1): (p, n) for (s, _, k, f), p, n in results}
    rows = []
    for (seed, d0, k, f), p, n in results:
        row = {"seed": seed, "sample": k, "measured": predict.MEASURED[k], "d0_m2_s": "%.6g" % d0, "size": "4N" if f > 1 else "N",
               "particles": n, "binary": version}
        if p:
            row.update({c: "%.5g" % p[c] for c in ("porosity_envelope", "porosity_mass", "porosity_mass_hold_end")})
            other = by.get((seed, k, False))[0] if f > 1 else None
            if other:
                row["envelope_4N_minus_N"] = "%+.4f" % (p["porosity_envelope"] - other["porosity_envelope"])
        rows.append(row)
    write_csv_atomic(a.csv, rows, fields)
    print(open(a.csv).read())


if __name__ == "__main__":
    main()
