#!/usr/bin/env python3
"""Compare a DEM run of configs/joule_notch_pack.json with the finite-volume reference.

    tools/fv_notch/compare_notch.py RUNDIR [--fv build/tools/fv_notch] [--grids 2,4,8]

Reads RUNDIR/summary.json (the `resistance` stage's final electrical_resistance, the fill and
solve wall times, the `notch` stage's deleted_particles) and the last frame (radii, positions,
electrode sets; read with h5py, Debian's python3-h5py), places the FV electrode planes at the
mean centre heights of the end_low / end_high sets (the DEM holds those centres), runs fv_notch
with r_mean of the frame (slab half-width 2 r_mean) and prints one JSON object:
  R_dem_ohm, R_fv_ohm (Richardson-extrapolated), error_pct = 100 (R_dem - R_fv) / R_fv,
  z_lo_m, z_hi_m, r_mean_m, particles, slab_particles (centres with |z - 3.5 mm| <= 2 r_mean),
  deleted, wall times, and the FV output under "fv".

tools/validate.py (ledger case seed001/notch) runs it on each packing before its thermal run: RUNDIR
is then <workdir>/<tier>/seed001_notch/N<n>_seed<s>/pack_out and the JSON is kept beside it as
fv_reference.log (layout: benchmarks/joule_notch/record_thermal.py).
"""
import argparse
import glob
import json
import os
import subprocess


def h5_dataset(path, name):
    """Every number of one dataset of an HDF5 file, flattened in row-major order, as Python floats."""
    import h5py
    with h5py.File(path, "r") as f:
        return [float(x) for x in f[name][()].ravel()]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rundir")
    ap.add_argument("--fv", default="build/tools/fv_notch")
    ap.add_argument("--grids", default="2,4,8")
    a = ap.parse_args()
    summary = json.load(open(os.path.join(a.rundir, "summary.json")))
    stages = {s["name"]: s for s in summary["stages"]}
    frame = sorted(glob.glob(os.path.join(a.rundir, "frames", "frame_*.h5")))[-1]
    pos = h5_dataset(frame, "/particles/position")
    rad = h5_dataset(frame, "/particles/radius")
    hi = h5_dataset(frame, "/particles/set_end_high")
    lo = h5_dataset(frame, "/particles/set_end_low")
    n = len(rad)
    z = [pos[3 * i + 2] for i in range(n)]
    r_mean = sum(rad) / n
    z_hi = [z[i] for i in range(n) if hi[i] > 0.5]
    z_lo = [z[i] for i in range(n) if lo[i] > 0.5]
    zl, zh = sum(z_lo) / len(z_lo), sum(z_hi) / len(z_hi)
    slab = sum(1 for x in z if abs(x - 3.5e-3) <= 2 * r_mean)
    fv = json.loads(subprocess.run([a.fv, "--r-mean", repr(r_mean), "--z-lo", repr(zl), "--z-hi", repr(zh),
                                    "--grids", a.grids], check=True, capture_output=True, text=True).stdout)
    R_dem = stages["resistance"]["final"]["electrical_resistance"]
    R_fv = fv["R_eq_ohm"]
    out = {
        "R_dem_ohm": R_dem, "R_fv_ohm": R_fv, "error_pct": 100.0 * (R_dem - R_fv) / R_fv,
        "R_fv_grid_band_ohm": fv["richardson"]["R_eq_ohm"]["error_band"],
        "particles": n, "deleted": stages["notch"].get("deleted_particles"),
        "r_mean_m": r_mean, "z_lo_m": zl, "z_hi_m": zh, "n_low": len(z_lo), "n_high": len(z_hi),
        "slab_particles": slab,
        "fill_wall_s": stages["cook"]["wall_time_s"], "fill_until_reached": stages["cook"].get("until_reached"),
        "packing": stages["cook"].get("packing", {}),
        "resistance_stage_wall_s": stages["resistance"]["wall_time_s"],
        "electrical_solve_s": stages["resistance"]["final"].get("electrical_solve_time"),
        "floating_nodes": stages["resistance"]["final"].get("electrical_floating_nodes"),
        "total_wall_s": summary["wall_time_s"],
        "fv": {k: fv[k] for k in ("loading", "richardson", "R_eq_ohm", "T_slab_mean_K", "T_max_K", "power_W")},
    }
    out["packing"].pop("coordination_histogram", None)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
