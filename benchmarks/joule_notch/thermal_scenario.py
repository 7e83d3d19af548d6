#!/usr/bin/env python3
"""The thermal stage of configs/joule_notch.json on a packing made by a joule_notch_pack run.

    benchmarks/joule_notch/thermal_scenario.py PACK_RUNDIR COMPARE_JSON > scenario.json

PACK_RUNDIR: output directory of `sparkdem run` on configs/joule_notch_pack.json (any particle
count; its final_state.h5 is the packing after the cut). COMPARE_JSON: the output of
tools/fv_notch/compare_notch.py on that directory (FV reference with the electrode planes at the
mean centre heights of the packing's end sets and the slab |z - 3.5 mm| <= 2 r_mean of the
packing), written BEFORE the thermal run: the references come from it and nothing else.

The scenario is configs/joule_notch.json's `joule` stage (frozen, 1 V, 10 ms, adiabatic,
capacity "domain") started from PACK_RUNDIR/final_state.h5 (`from_snapshot`), with the
`notch_slab` set and both checks (R_eq, slab-mean temperature rise) re-derived from COMPARE_JSON.
Python standard library only. tools/validate.py (ledger case seed001/notch) runs it between the
packing and the thermal run of each run directory (see record_thermal.py for the layout).
"""
import json
import os
import sys

here = os.path.dirname(os.path.abspath(__file__))
repo = os.path.dirname(os.path.dirname(here))


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rundir, cmp_path = sys.argv[1], sys.argv[2]
    cfg = json.load(open(os.path.join(repo, "configs", "joule_notch.json")))
    cmp = json.load(open(cmp_path))
    fv = cmp["fv"]
    ld = fv["loading"]
    T0 = 293.15
    joule = next(s for s in cfg["stages"] if s["name"] == "joule")
    joule = dict(joule)
    joule["from_snapshot"] = os.path.abspath(os.path.join(rundir, "final_state.h5"))
    hw = ld["slab_half_width_m"]
    sets = dict(cfg["particle_sets"])
    sets["notch_slab"] = {"type": "box", "lo": [-0.001, -0.001, 0.0035 - hw], "hi": [0.002, 0.002, 0.0035 + hw]}
    checks = []
    for c in cfg["checks"]:
        c = dict(c)
        if c["column"] == "electrical_resistance":
            c["reference"] = fv["R_eq_ohm"]
        else:
            c["reference"] = fv["T_slab_mean_K"] - T0
        c["source"] = f"tools/fv_notch via compare_notch.py: {os.path.abspath(cmp_path)}"
        checks.append(c)
    out = {"name": "joule_notch_thermal",
           "description": (f"configs/joule_notch.json's joule stage on the packing of {os.path.abspath(rundir)} "
                           f"({cmp['particles']} particles after the cut, r_mean {cmp['r_mean_m']:.6e} m); electrode planes "
                           f"z_lo = {cmp['z_lo_m']:.6e} m, z_hi = {cmp['z_hi_m']:.6e} m; references from {os.path.abspath(cmp_path)} "
                           f"(R_eq {fv['R_eq_ohm']:.6e} Ohm, slab-mean temperature {fv['T_slab_mean_K']:.3f} K), fixed before this run"),
           "seed": cfg["seed"], "materials": cfg["materials"], "contact": cfg["contact"],
           "particle_sets": sets, "stages": [joule], "checks": checks}
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
