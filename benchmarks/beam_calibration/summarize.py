#!/usr/bin/env python3
"""Per N, over the packing seeds: the elastic calibration's transfer and the two strength calibrations.

usage: benchmarks/beam_calibration/summarize.py   (reads this directory, writes summary.csv, prints it)

Inputs: results.csv, results_seed2.csv, results_seed3.csv (run.sh: the tension test at every N with
the committed beams) and bending.csv (bending.py: the pure-bending test). Per N: E_M / 124 GPa - 1
and nu_M / 0.29 - 1 (mean, std over seeds), the bond coordination, and the strength each test would
calibrate, sigma_t x (largest bond criterion / macroscopic stress), in tension and in bending
(mean, std), beside the strength the configs use (configs/materials/cast_iron_beams.json).
"""
import csv
import glob
import json
import math
import os
import statistics

HERE = os.path.dirname(os.path.abspath(__file__))
SIGMA_T = math.sqrt(3.0) * 400e6


def stats(xs):
    return (statistics.fmean(xs), statistics.stdev(xs) if len(xs) > 1 else math.nan, len(xs))


def main():
    tension = [r for f in sorted(glob.glob(os.path.join(HERE, "results*.csv"))) for r in csv.DictReader(open(f))]
    bending = list(csv.DictReader(open(os.path.join(HERE, "bending.csv"))))
    used = json.load(open(os.path.join(HERE, "..", "..", "configs", "materials", "cast_iron_beams.json")))["strength"]
    sizes = sorted({int(r["N"]) for r in tension} | {int(r["N"]) for r in bending})
    rows = []
    for n in sizes:
        t = [r for r in tension if int(r["N"]) == n]
        b = [r for r in bending if int(r["N"]) == n]
        row = {"N": n}
        for key, xs in (("err_E", [float(r["err_E"]) for r in t]), ("err_nu", [float(r["err_nu"]) for r in t]),
                        ("bonds_per_element", [float(r["coordination_bonds"]) for r in t]),
                        ("strength_tension_Pa", [SIGMA_T * float(r["criterion_to_macro_ratio"]) for r in t]),
                        ("strength_bending_Pa", [float(r["strength_Pa"]) for r in b]),
                        ("bending_stiffness", [float(r["stiffness"]) for r in b])):
            m, s, k = stats(xs) if xs else (math.nan, math.nan, 0)
            row[key + "_mean"], row[key + "_std"], row[key + "_seeds"] = m, s, k
        row["strength_used_Pa"] = used
        rows.append(row)
    with open(os.path.join(HERE, "summary.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    for r in rows:
        print("N=%6d  E_M %+.2f +- %.2f %% (%d)  nu_M %+.2f +- %.2f %%  bonds/el %.3f  strength: tension %.2f +- %.2f GPa (%d), "
              "bending %.2f +- %.2f GPa (%d), bending stiffness %.3f" % (
                  r["N"], 100 * r["err_E_mean"], 100 * r["err_E_std"], r["err_E_seeds"], 100 * r["err_nu_mean"],
                  100 * r["err_nu_std"], r["bonds_per_element_mean"], r["strength_tension_Pa_mean"] / 1e9,
                  r["strength_tension_Pa_std"] / 1e9, r["strength_tension_Pa_seeds"], r["strength_bending_Pa_mean"] / 1e9,
                  r["strength_bending_Pa_std"] / 1e9, r["strength_bending_Pa_seeds"], r["bending_stiffness_mean"]))


if __name__ == "__main__":
    main()
