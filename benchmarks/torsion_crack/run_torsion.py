#!/usr/bin/env python3
"""Pin-torsion convergence study (issue 7): configs/torsion_crack.json at several element counts.

usage: benchmarks/torsion_crack/run_torsion.py [--sizes "2500 5000 10000"] [--seeds "1"]
           [--sparkdem PATH] [--config FILE] [--workdir DIR] [--outdir DIR] [--threads N] [--reuse]

For each N (and seed) a copy of the config is written with only the element count changed and
the two lengths that follow the element size scaled with the mean radius (r ~ N^(-1/3)): the bond
gap tolerance and the end-set thickness. Every other parameter (the calibrated beams included) is
the config's. Each run's summary.json gives the figures; results.csv / results.md hold, per run:
the onset twist (first broken bond) against the prediction tau_y L / (G r) = 0.0416 rad, the
resistance-rise and separation twists, R/R0 at 0.05 / 0.06 / 0.07 rad, the elastic stiffness
ratio k / (G J / L), the bonds made and broken, the largest kinetic / elastic energy ratio before
the first break, and the wall and CPU time of the run (the relax packing is part of it).

The validation figures (elastic stiffness, first-break twist, 1 % resistance-rise twist) are the
ledger's cases seed001/torsion_stiffness, seed001/torsion_onset and seed001/torsion_onset_resistance
(benchmarks/validation/ledger.md), run by tools/validate.py with scene_for() below: one directory
per run, <workdir>/<tier>/seed001_torsion/N<n>_seed<s>/, holding scenario.json, out/ and
scenario.meta.json (exit code, wall and CPU seconds). This script stays for the study's other
columns (R/R0 along the twist, separation, larger N). The tables it wrote into this directory
were superseded by the ledger and removed: pass a scratch --outdir (the default is still this
directory).
"""
import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
PREDICTED_ONSET = 400e6 * 5e-3 / (48.062e9 * 1e-3)  # tau_y L / (G r) [rad]


def expand_includes(x, base):
    """Inline every {"$include": file, ...} object (paths relative to `base`), as the loader does."""
    if isinstance(x, dict):
        if "$include" in x:
            inc = os.path.join(base, x["$include"])
            merged = expand_includes(json.load(open(inc)), os.path.dirname(inc))
            merged.update({k: expand_includes(v, base) for k, v in x.items() if k != "$include"})
            return merged
        return {k: expand_includes(v, base) for k, v in x.items()}
    if isinstance(x, list):
        return [expand_includes(v, base) for v in x]
    return x


def scene_for(config, n, seed):
    j = expand_includes(json.load(open(config)), os.path.dirname(os.path.abspath(config)))
    n0 = j["stages"][0]["generator"]["particles"]
    scale = (n0 / n) ** (1.0 / 3.0)
    j["stages"][0]["generator"]["particles"] = n
    if seed is not None:
        j["seed"] = seed
    for st in j["stages"]:
        if "gap_tolerance" in st.get("create_bonds", {}):  # absolute [m]; gap_tolerance_relative follows the radii
            st["create_bonds"]["gap_tolerance"] *= scale
    for s in j["particle_sets"].values():
        if "thickness" in s:
            s["thickness"] *= scale
    return j


def energy_ratio_before_break(run):
    worst = 0.0
    with open(os.path.join(run, "timeseries.csv"), newline="") as f:
        for r in csv.DictReader(f):
            try:
                if float(r["bonds_broken"]) > 0:
                    break
                ke, ue = float(r["kinetic_energy"]), float(r["bonds_elastic_energy"])
            except (KeyError, ValueError):
                continue
            if ue > 0 and float(r["torsion_twist"]) > 0.005:
                worst = max(worst, ke / ue)
    return worst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="2500 5000 10000")
    ap.add_argument("--seeds", default="")
    ap.add_argument("--sparkdem", default=os.environ.get("SPARKDEM_BIN", os.path.join(REPO, "build", "sparkdem")))
    ap.add_argument("--config", default=os.path.join(REPO, "configs", "torsion_crack.json"))
    ap.add_argument("--workdir", default="/tmp/sparkdem_torsion")
    ap.add_argument("--outdir", default=HERE)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    seeds = [int(s) for s in a.seeds.split()] or [None]
    rows = []
    for n in [int(x) for x in a.sizes.split()]:
        for seed in seeds:
            name = "N%d" % n + ("" if seed is None else "_seed%d" % seed)
            run_dir = os.path.join(a.workdir, name)
            os.makedirs(run_dir, exist_ok=True)
            scene = scene_for(a.config, n, seed)
            scene_file = os.path.join(run_dir, "scenario.json")
            scene_text = json.dumps(scene, indent=1)
            summary = os.path.join(run_dir, "out", "summary.json")
            fresh = not (a.reuse and os.path.exists(summary) and open(scene_file).read() == scene_text) if os.path.exists(scene_file) else True
            if fresh:
                open(scene_file, "w").write(scene_text)
                t0 = time.time()
                c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                env = dict(os.environ, OMP_WAIT_POLICY="PASSIVE")
                with open(os.path.join(run_dir, "sparkdem.log"), "w") as log:
                    rc = subprocess.call([a.sparkdem, "run", scene_file, "-o", os.path.join(run_dir, "out"), "--threads",
                                          str(a.threads), "--quiet", "--report-only"], stdout=log, stderr=log, env=env)
                c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                meta = {"rc": rc, "wall_s": time.time() - t0, "cpu_s": (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime),
                        "load_start": os.getloadavg()[0]}
                json.dump(meta, open(os.path.join(run_dir, "bench_meta.json"), "w"))
            meta = json.load(open(os.path.join(run_dir, "bench_meta.json")))
            if meta["rc"] != 0:
                print("%s failed (exit %d): see %s/sparkdem.log" % (name, meta["rc"], run_dir), file=sys.stderr)
                continue
            s = json.load(open(summary))
            tw = [st for st in s["stages"] if "torsion_twist" in st.get("final", {})]
            f = tw[-1]["final"]
            pack = s["stages"][0]
            bonds_made = sum(st.get("bonds_created", 0) for st in s["stages"])
            onset = f.get("torsion_break_onset_twist")
            get = lambda k: f.get(k) if f.get(k) is not None else math.inf
            rows.append({
                "N": n, "seed": "" if seed is None else seed, "bonds": bonds_made, "bonds_broken": f.get("bonds_broken"),
                "onset_twist_rad": onset, "onset_error": (onset / PREDICTED_ONSET - 1) if onset is not None else None,
                "resistance_onset_rad": f.get("torsion_resistance_onset_twist"),
                "separation_rad": f.get("torsion_separation_twist"),
                "R_ratio_0.05": get("torsion_resistance_ratio_at_0.05"), "R_ratio_0.06": get("torsion_resistance_ratio_at_0.06"),
                "R_ratio_0.07": get("torsion_resistance_ratio_at_0.07"),
                "stiffness_ratio": f.get("torsion_stiffness_ratio"),
                "max_KE_over_elastic_before_break": energy_ratio_before_break(os.path.join(run_dir, "out")),
                "pack_wall_s": pack.get("wall_time_s"), "twist_wall_s": tw[-1]["wall_time_s"],
                "run_wall_s": meta["wall_s"], "run_cpu_s": meta["cpu_s"], "load_at_start": meta["load_start"],
            })
            print(rows[-1])
    if not rows:
        sys.exit("no completed run")
    os.makedirs(a.outdir, exist_ok=True)
    with open(os.path.join(a.outdir, "results.csv"), "w", newline="") as fcsv:
        w = csv.DictWriter(fcsv, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    fmt = lambda x: "—" if x is None else ("inf" if isinstance(x, float) and math.isinf(x) else ("%.4g" % x if isinstance(x, float) else str(x)))
    with open(os.path.join(a.outdir, "results.md"), "w") as md:
        md.write("Predicted onset tau_y L / (G r) = %.4f rad (band 5 %%).\n\n" % PREDICTED_ONSET)
        md.write("| " + " | ".join(rows[0].keys()) + " |\n|" + "---|" * len(rows[0]) + "\n")
        for r in rows:
            md.write("| " + " | ".join(fmt(v) for v in r.values()) + " |\n")
    print("wrote %s/results.csv and results.md" % a.outdir)


if __name__ == "__main__":
    main()
