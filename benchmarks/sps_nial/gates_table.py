#!/usr/bin/python3
"""The quasi-static gates and kappa of the hot press's snapshots as a markdown table, from CSVs of
benchmarks/sps_nial/step_halving.py (one or more seeds; dt_factor 1 rows for the ensemble, the
other factors for the step-halving column): per snapshot, mean +- std over the seeds.

    python3 -m benchmarks.sps_nial.gates_table CSV [CSV ...]
"""
import csv
import statistics
import sys

from tools import sps_outputs as so


def fmt(values, digits):
    vals = [v for v in values if v is not None]
    if not vals:
        return "-"
    short = f" (n = {len(vals)})" if len(vals) < len(values) else ""  # e.g. a seed whose core region is empty
    if len(vals) == 1:
        return f"{vals[0]:.{digits}g}{short}"
    return f"{statistics.mean(vals):.{digits}g} ± {statistics.stdev(vals):.2g}{short}"


def number(row, key):
    v = row.get(key, "")
    x = float(v) if v not in ("", None) else None
    return x if x is None or x == x else None  # NaN (e.g. an empty core): no value


def main(paths):
    rows = [r for p in paths for r in csv.DictReader(open(p))]
    ref = [r for r in rows if float(r["dt_factor"]) == 1.0]
    half = [r for r in rows if float(r["dt_factor"]) != 1.0]
    snaps = sorted({int(r["snapshot"]) for r in ref})
    seeds = sorted({r.get("seed", "?") for r in ref})
    targets = {int(r["snapshot"]): r["target"] for r in ref}
    lines = [f"| quantity ({len(seeds)} seeds: {', '.join(seeds)}) | " + " | ".join(targets[k] for k in snaps) + " |",
             "|---|" + "---|" * len(snaps)]

    def line(label, key, digits, scale=1.0, source=ref):
        per = [fmt([number(r, key) * scale if number(r, key) is not None else None for r in source if int(r["snapshot"]) == k], digits)
               for k in snaps]
        lines.append(f"| {label} | " + " | ".join(per) + " |")

    line("porosity taken", "porosity_taken", 3)
    for q in so.QUANTITIES:
        line(q.replace("_", " "), "qs_" + q, 4 if q.startswith("envelope") else 3)
    line("kappa without layer [MS/m]", "kappa_without_layer", 3, 1e-6)
    line("kappa with layer [MS/m] (calibrated on 0.164)", "kappa_with_layer", 3, 1e-6)
    if half:
        line("kappa without layer, step halved: change [%]", "kappa_without_layer_change", 2, 100.0, half)
        line("kappa with layer, step halved: change [%]", "kappa_with_layer_change", 2, 100.0, half)
        line("porosity taken, step halved", "porosity_taken", 4, 1.0, half)
    binaries = sorted({r["binary"] for r in rows})
    print("\n".join(lines))
    print("\nbinary: " + "; ".join(binaries))


if __name__ == "__main__":
    main(sys.argv[1:])
