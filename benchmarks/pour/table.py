#!/usr/bin/env python3
"""Prints the pour "Measured" tables of benchmarks/README.md from benchmarks/pour/results.csv.

    python3 benchmarks/pour/table.py [results.csv]

Every figure printed comes from the CSV (written by run_pour.sh / analyze_pour.py, columns
explained in benchmarks/README.md); the ratios are computed here. Paste the output between
`<!-- generated: benchmarks/pour/table.py -->` and `<!-- end generated -->`. Standard library only.
"""
import csv
import os
import sys

KE_COLUMNS = "ke_at_"


def label(r):
    if r["code"] == "lammps":
        return "LAMMPS " + r["variant"] + (f" ({r['mpi_ranks']} MPI ranks)" if int(r["mpi_ranks"]) > 1 else "")
    return f"sparkdem, {r['threads']} thread{'s' if int(r['threads']) > 1 else ''}"


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    path = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "results.csv")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    ref = next((r for r in rows if r["code"] == "lammps" and r["variant"] == "serial"), None)
    one = next((r for r in rows if r["code"] == "sparkdem" and r["threads"] == "1"), None)
    ke = [c for c in rows[0] if c.startswith(KE_COLUMNS)]

    def ratio(r, col):  # speed relative to LAMMPS serial = its time / this run's time (> 1: faster)
        return f"{float(ref[col]) / float(r[col]):.2f}" if ref else ""

    print(f"`{os.path.relpath(path, os.path.join(here, '..', '..'))}`, {rows[0]['particles']} particles, "
          f"{rows[0]['steps']} steps:")
    print()
    print("| run | OpenMP variant | whole process [s] | loop [s] | particle-steps/s (loop) | speed / LAMMPS serial (whole process) "
          "| speed / LAMMPS serial (loop) | bed height [mm] | coordination |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        variant = r["variant"] if r["code"] == "sparkdem" else ""
        print(f"| {label(r)} | {variant} | {float(r['wall_s']):.1f} | {float(r['loop_s']):.1f} | "
              f"{float(r['particle_steps_per_s']):.3g} | {ratio(r, 'wall_s')} | {ratio(r, 'loop_s')} | "
              f"{1e3 * float(r['bed_height_m']):.3f} | {float(r['mean_coordination']):.3f} |")
    print()
    print("Kinetic energy (translational + rotational) [J], and its difference from LAMMPS serial:")
    print()
    print("| run | " + " | ".join(f"step {c[len(KE_COLUMNS):-2]}" for c in ke) + " |")
    print("|---|" + "---|" * len(ke))
    for r in rows:
        cells = []
        for c in ke:
            x = float(r[c])
            d = f" ({100 * (x / float(ref[c]) - 1):+.2g} %)" if ref and r is not ref else ""
            cells.append(f"{x:.6g}{d}")
        print(f"| {label(r)} | " + " | ".join(cells) + " |")
    if one:
        for r in rows:
            if r["code"] == "sparkdem" and r is not one:
                same = all(r[c] == one[c] for c in ke + ["bed_height_m", "mean_coordination"])
                print()
                print(f"- {label(r)}: {float(one['loop_s']) / float(r['loop_s']):.2f} times the 1-thread loop rate; "
                      f"kinetic energies, bed height and coordination {'equal to' if same else 'differ from'} "
                      f"the 1-thread run's in every printed digit of results.csv.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
