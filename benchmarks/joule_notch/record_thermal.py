#!/usr/bin/env python3
"""One JSON record of a notched-rod thermal run against its FV reference (standard library only).

    benchmarks/joule_notch/record_thermal.py THERMAL_RUNDIR COMPARE_JSON [META] > record.json

THERMAL_RUNDIR: output of `sparkdem run` on the scenario of thermal_scenario.py (or on
configs/joule_notch.json itself); COMPARE_JSON: the packing's compare_notch.py output (its FV
reference and packing figures, fixed before the thermal run); META: optional GNU time file
(time_wall_user_sys). Errors: 100 (DEM - FV) / FV of R_eq, of the slab-mean temperature rise
(the checked figure) and, as a variant, of the absolute slab temperature in K; diagnostic: the
slab rise per watt of total power (DEM power V^2/R_DEM against the FV's), which removes R_eq's error.
"""
import json
import os
import sys


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    rundir, cmp_path = sys.argv[1], sys.argv[2]
    s = json.load(open(os.path.join(rundir, "summary.json")))
    cmp = json.load(open(cmp_path))
    fv = cmp["fv"]
    T0 = fv["loading"]["T0_K"]
    st = {x["name"]: x for x in s["stages"]}
    j = st["joule"]
    f = j["final"]
    R, Ts = f["electrical_resistance"], f["heat_temperature_mean_notch_slab"]
    out = {
        "particles": j["particles"], "r_mean_m": cmp["r_mean_m"], "z_lo_m": cmp["z_lo_m"], "z_hi_m": cmp["z_hi_m"],
        "slab_particles": j.get("particle_sets", {}).get("notch_slab"),
        "R_dem_ohm": R, "R_fv_ohm": fv["R_eq_ohm"], "R_error_pct": 100 * (R / fv["R_eq_ohm"] - 1),
        "T_slab_dem_K": Ts, "T_slab_fv_K": fv["T_slab_mean_K"],
        "rise_error_pct": 100 * ((Ts - T0) / (fv["T_slab_mean_K"] - T0) - 1),
        "T_abs_error_pct_variant": 100 * (Ts / fv["T_slab_mean_K"] - 1),
        # diagnostic: the slab rise per watt of total power (removes the R_eq error at fixed voltage)
        "rise_per_power_error_pct": 100 * (((Ts - T0) / f["electrical_power"]) / ((fv["T_slab_mean_K"] - T0) / fv["power_W"]) - 1),
        "T_max_dem_K": f["heat_temperature_max"], "T_max_fv_K": fv["T_max_K"],
        "power_dem_W": f["electrical_power"], "power_fv_W": fv["power_W"],
        "heat_balance_error": f["heat_balance_error"], "heat_capacity_ratio": f["heat_capacity_ratio"],
        "floating_nodes": f.get("electrical_floating_nodes"),
        "joule_stage_wall_s": j["wall_time_s"], "run_wall_s": s["wall_time_s"],
        "packing_wall_s": cmp.get("fill_wall_s"), "checks": s.get("checks"),
        "compare_json": os.path.abspath(cmp_path), "thermal_rundir": os.path.abspath(rundir),
    }
    if "cook" in st:
        out["packing_wall_s_this_run"] = st["cook"].get("wall_time_s")
    if len(sys.argv) == 4:
        for line in open(sys.argv[3]):
            k, _, v = line.strip().partition(" ")
            if k == "time_wall_user_sys":
                w, u, sy = (float(x) for x in v.split())
                out["process_wall_s"], out["process_cpu_s"] = w, u + sy
            elif k in ("load_start", "load_end"):
                out[k] = v
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
