#!/usr/bin/python3
"""Which bond failure criterion transfers from the tension calibration to the pin (issue 20, steps 2-3).

    criteria_study.py twist   --workdir DIR [--sizes 2500 5000 10000] [--seeds 1 2 3 4 5] [--jobs 2]
                              [--twist 0.02] [--sparkdem build/sparkdem]
    criteria_study.py analyze --workdir DIR --tension RUN_DIR... --calibration RUN_DIR
                              [--bond-criteria build/benchmarks/beam_calibration/bond_criteria] [--out PREFIX]

`twist` runs configs/torsion_crack.json (run_torsion.scene_for: N and seed patched, lengths scaled
with the element size) with unbreakable beams (strength 1e30) up to an elastic twist theta_e
(default 0.02 rad, half the predicted onset), one process per run, --threads 1.

`analyze` runs bond_criteria (benchmarks/beam_calibration/bond_criteria.cpp: the engine's beam
kernel on the final checkpoint) on
  - the tension runs (benchmarks/beam_calibration/run.sh work directories N<n>_seed<s>): per
    criterion k, the strength a calibration at that N and seed gives,
    sigma_k = sigma_t max_bonds(k) / sigma_macro (sigma_t = sqrt(3) 400 MPa, the config's target);
  - the calibration run (N = 4000, seed 1; the strength the shipped beams carry);
  - the elastic twists: the predicted first break theta_k = theta_e sigma_k / max_bonds(k)
    (linear elastic up to the first break), with sigma_k from the calibration run (one strength
    for every N) and from the tension runs at the same N (mean over their seeds).
Writes PREFIX_tension.csv, PREFIX_onset.csv and PREFIX.md (default PREFIX: DIR/criteria).
The criteria: the beam's max_normal (André 2012), von_mises, tresca, and bond_virial_failure's
hydrostatic virial stress (the mean of the bond's two elements) and the von Mises stress of their mean
virial tensor (physics/bonds/virial_failure.hpp).
"""
import argparse
import concurrent.futures
import csv
import io
import json
import math
import os
import statistics
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
from benchmarks.torsion_crack import run_torsion

CRITERIA = ["max_normal", "von_mises", "tresca", "virial_hydrostatic", "virial_von_mises"]
SIGMA_T = math.sqrt(3.0) * 400e6  # configs/calibration/cast_iron.json target (von Mises reading of tau_y)
PREDICTED = run_torsion.PREDICTED_ONSET


def twist_scene(n, seed, theta):
    j = run_torsion.scene_for(os.path.join(REPO, "configs", "torsion_crack.json"), n, seed)
    j["bonds"]["params"]["strength"] = 1e30
    tw = next(st for st in j["stages"] if st["name"] == "twist")
    omega = tw["prescribe"]["twisted"]["angular_velocity"][2]
    tw["stop"] = {"time": theta / omega}
    j["checks"] = []
    return j


def run_one(args, n, seed):
    d = os.path.join(args.workdir, f"twist_N{n}_seed{seed}")
    if finished(d):
        return d
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "scenario.json"), "w") as f:
        json.dump(twist_scene(n, seed, args.twist), f, indent=1)
    subprocess.run([args.sparkdem, "run", os.path.join(d, "scenario.json"), "-o", os.path.join(d, "out"), "--threads", "1",
                    "--quiet"], check=False)
    return d


def cmd_twist(args):
    jobs = [(n, s) for s in args.seeds for n in args.sizes]
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as ex:
        for d in ex.map(lambda p: run_one(args, *p), jobs):
            print("done", d, flush=True)


def finished(run):
    """A run whose summary.json says completed (a run in progress has the packing's checkpoint only)."""
    try:
        with open(os.path.join(run, "out", "summary.json")) as f:
            return json.load(f).get("status") == "completed"
    except (OSError, ValueError):
        return False


def criteria(tool, dirs):
    params = os.path.join(REPO, "configs", "materials", "cast_iron_beams.json")
    out = subprocess.run([tool, params] + dirs, capture_output=True, text=True, check=True).stdout
    return list(csv.DictReader(io.StringIO(out)))


def mean_std(xs):
    return statistics.mean(xs), (statistics.stdev(xs) if len(xs) > 1 else 0.0)


def cmd_analyze(args):
    prefix = args.out or os.path.join(args.workdir, "criteria")
    tension = criteria(args.bond_criteria, args.tension)
    cal = criteria(args.bond_criteria, [args.calibration])[0]
    twists = sorted(d for d in (os.path.join(args.workdir, x) for x in os.listdir(args.workdir))
                    if os.path.basename(d).startswith("twist_N") and finished(d))
    tw = criteria(args.bond_criteria, twists)

    def strength(row, k):
        return SIGMA_T * float(row[k + "_Pa"]) / float(row["load_value"])

    s_cal = {k: strength(cal, k) for k in CRITERIA}
    s_at_n = {}
    trows = []
    for r in tension:
        n = int(r["N"])
        row = {"run": r["run"], "N": n}
        for k in CRITERIA:
            row["strength_" + k + "_Pa"] = strength(r, k)
            s_at_n.setdefault((k, n), []).append(strength(r, k))
        trows.append(row)
    orows = []
    for r in tw:
        n, theta = int(r["N"]), float(r["load_value"])
        row = {"run": r["run"], "N": n, "theta_e_rad": theta}
        for k in CRITERIA:
            m = float(r[k + "_Pa"])
            row["onset_" + k + "_cal4000"] = theta * s_cal[k] / m
            if (k, n) in s_at_n:
                row["onset_" + k + "_same_N"] = theta * statistics.mean(s_at_n[(k, n)]) / m
        orows.append(row)
    for path, rows in ((prefix + "_tension.csv", trows), (prefix + "_onset.csv", orows)):
        keys = []
        for r in rows:
            keys += [k for k in r if k not in keys]
        with open(path + ".tmp", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
        os.replace(path + ".tmp", path)
    lines = ["# Bond criteria: tension calibration against the pin's elastic twist", "",
             f"Calibration run (N = {cal['N']}): " + ", ".join(f"{k} {s_cal[k] / 1e9:.4g} GPa" for k in CRITERIA), "",
             "## Strength calibrated in tension, per N (mean ± std over seeds; spread = (max - min) / mean of the N means)", "",
             "| criterion | " + " | ".join(f"N = {n}" for n in sorted({r['N'] for r in trows})) + " | spread over N |",
             "|---|" + "---|" * (len({r['N'] for r in trows}) + 1)]
    for k in CRITERIA:
        means = []
        cells = []
        for n in sorted({r["N"] for r in trows}):
            m, s = mean_std([r["strength_" + k + "_Pa"] for r in trows if r["N"] == n])
            means.append(m)
            cells.append(f"{m / 1e9:.4g} ± {s / 1e9:.2g} GPa")
        lines.append(f"| {k} | " + " | ".join(cells) + f" | {100 * (max(means) - min(means)) / statistics.mean(means):.1f} % |")
    lines += ["", f"## Predicted first break of the pin against tau_y L / (G r) = {PREDICTED:.4f} rad (mean ± std over seeds)", "",
              "| criterion | strength from | " + " | ".join(f"N = {n}" for n in sorted({r['N'] for r in orows})) + " |",
              "|---|---|" + "---|" * len({r['N'] for r in orows})]
    for k in CRITERIA:
        for src in ("cal4000", "same_N"):
            cells = []
            for n in sorted({r["N"] for r in orows}):
                xs = [r["onset_" + k + "_" + src] for r in orows if r["N"] == n and ("onset_" + k + "_" + src) in r]
                if not xs:
                    cells.append("–")
                    continue
                m, s = mean_std(xs)
                cells.append(f"{100 * (m / PREDICTED - 1):+.1f} ± {100 * s / PREDICTED:.1f} % ({len(xs)})")
            lines.append(f"| {k} | {'N = 4000 calibration' if src == 'cal4000' else 'tension at the same N'} | " + " | ".join(cells) + " |")
    with open(prefix + ".md.tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(prefix + ".md.tmp", prefix + ".md")
    print("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("twist")
    p.add_argument("--workdir", required=True)
    p.add_argument("--sizes", nargs="+", type=int, default=[2500, 5000, 10000])
    p.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5])
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--twist", type=float, default=0.02)
    p.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    p.set_defaults(fn=cmd_twist)
    p = sub.add_parser("analyze")
    p.add_argument("--workdir", required=True)
    p.add_argument("--tension", nargs="+", required=True)
    p.add_argument("--calibration", required=True)
    p.add_argument("--bond-criteria", default=os.path.join(REPO, "build", "benchmarks", "beam_calibration", "bond_criteria"))
    p.add_argument("--out")
    p.set_defaults(fn=cmd_analyze)
    a = ap.parse_args()
    a.fn(a)


if __name__ == "__main__":
    main()
