#!/usr/bin/python3
"""Where the cylinder's resistance error lives (issue 19, step 1), on runs of the ledger case
seed001/cylinder (tools/validate.py; run directories N<n>_seed<s>/out with the final frame).

    /usr/bin/python3 benchmarks/resistance_cylinder/locate_error.py RUN_DIR [RUN_DIR ...]

Per run, from the last frame (particle potentials, branch currents of /networks/electrical):
  R/R_th - 1          the ledger's figure (R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2))
  electrode share     (R - R_mid) / R, R_mid = |dphi/dz| L_c / I: the potential gradient fitted
                      over the middle half of the length times the distance of the electrode sets'
                      centroids; what the end layers add beyond the bulk
  annulus kappa       the axial current crossing 21 planes in the middle half, split by the radius
                      of the crossing point, over (annulus area x |dphi/dz|): the effective
                      conductivity of each ring against 1/rho_e (0 = the continuum)
Geometry and rho_e are seed 001's (r_d = 1 mm, l_d = 5 mm, 304L 0.73e-6 Ohm m).
"""
import glob
import json
import os
import sys

import h5py
import numpy as np

RHO, RD, LD = 0.73e-6, 1e-3, 5e-3
EDGES = [0.0, 0.5e-3, 0.7e-3, 0.85e-3, 1.2e-3]


def ring_kappa_arrays(x, phi, ia, ib, cur, edges, length=LD, rd=RD):
    """The effective conductivity of each ring edges[k] <= r < edges[k + 1] [S/m]: the axial current
    |cur| of the branches (ia, ib) crossing 21 planes over the middle half of the length, split by
    the radius of the crossing point, over (ring area x |dphi/dz|), dphi/dz of the node potentials
    phi fitted over the same middle half. Returns (kappa per ring, |dphi/dz|)."""
    z = x[:, 2]
    zc = 0.5 * (z.min() + z.max())
    mid = (np.abs(z - zc) < 0.25 * length) & np.isfinite(phi)
    grad = abs(np.polyfit(z[mid], phi[mid], 1)[0])
    ring = np.zeros(len(edges) - 1)
    planes = zc + np.linspace(-0.25 * length, 0.25 * length, 21)
    for zp in planes:
        cross = (z[ia] - zp) * (z[ib] - zp) < 0
        t = (zp - z[ia][cross]) / (z[ib][cross] - z[ia][cross])
        pt = x[ia][cross] + t[:, None] * (x[ib][cross] - x[ia][cross])
        k = np.clip(np.searchsorted(edges, np.hypot(pt[:, 0], pt[:, 1])) - 1, 0, len(ring) - 1)
        np.add.at(ring, k, np.abs(cur[cross]) / len(planes))
    outer = np.minimum(np.array(edges[1:]), rd)
    areas = np.pi * (outer ** 2 - np.array(edges[:-1]) ** 2)
    return ring / (areas * grad), grad


def ring_kappa(f, edges, length=LD, rd=RD):
    """ring_kappa_arrays on the last frame `f` (an open h5py file): its particle potentials and the
    branch currents of /networks/electrical."""
    p = f["particles"]
    x = p["position"][:]
    phi, ids = p["electric_potential"][:].ravel(), p["id"][:].ravel()
    index = {int(i): k for k, i in enumerate(ids)}
    pairs, branch_i = f["networks/electrical/pairs"][:], f["networks/electrical/current"][:].ravel()
    keep = (pairs[:, 0] >= 0) & (pairs[:, 1] >= 0)
    ia = np.array([index[int(a)] for a in pairs[keep, 0]])
    ib = np.array([index[int(b)] for b in pairs[keep, 1]])
    return ring_kappa_arrays(x, phi, ia, ib, branch_i[keep], edges, length, rd)


def deep_bulk(out, depth=6.0, rho=RHO, rd=RD, length=LD):
    """Issue 58's gate G3 and the electrodes' share of G4, from a run's output directory `out`:
    deep_kappa_rho  kappa rho_e of the disc r < r_d - depth r_mean (ring_kappa over 21 planes of the
                    middle half; 1 = the continuum), the bulk free of the wall layering
    electrode_share (R - R_mid) / R, R_mid = |dphi/dz| x (distance of the end sets' centroids) / I"""
    with h5py.File(sorted(glob.glob(os.path.join(out, "frames", "*.h5")))[-1], "r") as f:
        p = f["particles"]
        r_mean = float(p["radius"][:].mean())
        z = p["position"][:][:, 2]
        hi, lo = p["set_end_high"][:].ravel() > 0.5, p["set_end_low"][:].ravel() > 0.5
        # the outer ring closes the edges: ring_kappa clips a crossing beyond the last edge into the last ring
        kappa, grad = ring_kappa(f, [0.0, rd - depth * r_mean, 2.0 * rd], length, rd)
    with open(os.path.join(out, "summary.json")) as f:
        fin = [t for t in json.load(f)["stages"] if "electrical_resistance" in t.get("final", {})][-1]["final"]
    r_mid = grad * (z[hi].mean() - z[lo].mean()) / fin["electrical_current"]
    return {"deep_kappa_rho": float(kappa[0] * rho), "deep_radius_m": rd - depth * r_mean,
            "electrode_share": float((fin["electrical_resistance"] - r_mid) / fin["electrical_resistance"])}


def analyse(run):
    f = h5py.File(sorted(glob.glob(run + "/out/frames/*.h5"))[-1], "r")
    p = f["particles"]
    x, r = p["position"][:], p["radius"][:].ravel()
    hi, lo = p["set_end_high"][:].ravel() > 0.5, p["set_end_low"][:].ravel() > 0.5
    s = json.load(open(run + "/out/summary.json"))
    fin = [t for t in s["stages"] if "electrical_resistance" in t.get("final", {})][-1]["final"]
    current, resistance = fin["electrical_current"], fin["electrical_resistance"]
    z = x[:, 2]
    kappa, grad = ring_kappa(f, EDGES)
    r_th = RHO * (LD - 2.0 * r.mean()) / (np.pi * RD ** 2)
    r_mid = grad * (z[hi].mean() - z[lo].mean()) / current
    outer = np.minimum(np.array(EDGES[1:]), RD)
    rings = ", ".join(f"r {1e3 * EDGES[i]:.2f}-{1e3 * outer[i]:.2f} mm {100 * (kappa[i] * RHO - 1):+.1f} %"
                      for i in range(len(kappa)))
    print(f"{run}: R/R_th - 1 {100 * (resistance / r_th - 1):+.2f} %, electrode share "
          f"{100 * (resistance - r_mid) / resistance:+.2f} %; kappa rho_e - 1 by ring: {rings}")


if __name__ == "__main__":
    for d in sys.argv[1:] or sys.exit(__doc__):
        analyse(d.rstrip("/"))
