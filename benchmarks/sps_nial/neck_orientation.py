#!/usr/bin/python3
"""Issue 59 gate G4: which necks saturate under a press, and why a uniform map saturates fewer?

For each checkpoint-format state given (a press snapshot, or the packed state mapped by
--affine), splits the overlapping pairs by orientation: "axial" when the centre line is within
45 degrees of the pressing axis z (29.3 % of an isotropic set), "lateral" otherwise, and reports
per group the mean overlap h / r_min and the share of pairs whose neck a / r_min exceeds 0.9 (a the
Coble neck sqrt(2 r* h), r* = r_i r_j / (r_i + r_j), capped at 1: the proxy of the network's CV
neck before Eq. 25). An isotropic strain deepens every contact alike (ratio 1); a uniaxial one
deepens the axial contacts about three times the lateral ones.

    python3 -m benchmarks.sps_nial.neck_orientation --state FILE LABEL [--state FILE LABEL ...]
        [--affine PACKED.h5 POROSITY] [--csv benchmarks/sps_nial/neck_orientation.csv]

--affine maps the packed state's positions (radii kept) to the porosity by mass POROSITY, about
the die axis on the lower punch, isotropically and uniaxially (as cases.run_nial_affine does;
the packed porosity by mass from the die and punch positions, spheres not clipped).
"""
import argparse
import os

import h5py
import numpy as np
from scipy.spatial import cKDTree

from benchmarks.perf.harness import write_csv_atomic

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def orientation_row(x, r, label):
    pairs = cKDTree(x).query_pairs(2.0 * r.max(), output_type="ndarray")
    d = np.linalg.norm(x[pairs[:, 1]] - x[pairs[:, 0]], axis=1)
    h = r[pairs[:, 0]] + r[pairs[:, 1]] - d
    keep = h > 0.0
    pairs, d, h = pairs[keep], d[keep], h[keep]
    ri, rj = r[pairs[:, 0]], r[pairs[:, 1]]
    axial = np.abs(x[pairs[:, 1], 2] - x[pairs[:, 0], 2]) / d > np.cos(np.pi / 4.0)
    depth = h / np.minimum(ri, rj)
    neck = np.minimum(np.sqrt(2.0 * ri * rj / (ri + rj) * h) / np.minimum(ri, rj), 1.0)
    return {"state": label, "pairs": len(h), "pairs_per_particle": 2.0 * len(h) / len(r), "axial_share": axial.mean(),
            "depth_axial": depth[axial].mean(), "depth_lateral": depth[~axial].mean(),
            "depth_ratio": depth[axial].mean() / depth[~axial].mean(),
            "saturated_axial": (neck[axial] > 0.9).mean(), "saturated_lateral": (neck[~axial] > 0.9).mean()}


def read(path):
    with h5py.File(path, "r") as f:
        return f["state/particles/position"][()], f["state/particles/radius"][()]


def affine_states(path, porosity):
    """The packed state mapped isotropically and uniaxially to `porosity` by mass."""
    with h5py.File(path, "r") as f:
        x, r = f["state/particles/position"][()], f["state/particles/radius"][()]
        die = f["state/walls/die/geometry"][()][0]
        u_die = float(f["state/walls/die/u"][()])
        bottom, u_b = f["state/walls/bottom/geometry"][()][0], float(f["state/walls/bottom/u"][()])
        top, u_t = f["state/walls/top/geometry"][()][0], float(f["state/walls/top/u"][()])
    zb, zt, R = bottom[2] + u_b * bottom[5], top[2] + u_t * top[5], die[6] - u_die
    p0 = 1.0 - (4.0 / 3.0 * np.pi * r ** 3).sum() / (np.pi * R * R * (zt - zb))
    ratio = (1.0 - p0) / (1.0 - porosity)
    out = []
    for mode, s in (("isotropic", [ratio ** (1.0 / 3.0)] * 3), ("uniaxial", [1.0, 1.0, ratio])):
        origin = np.array([die[0], die[1], zb])
        y = origin + np.array(s) * (x - origin)
        out.append((y, r, f"{mode} map of the packed state (p0 {p0:.3f}) to {porosity}"))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--state", nargs=2, action="append", default=[], metavar=("FILE", "LABEL"))
    ap.add_argument("--affine", nargs=2, metavar=("PACKED", "POROSITY"))
    ap.add_argument("--csv", default=os.path.join(REPO, "benchmarks/sps_nial/neck_orientation.csv"))
    a = ap.parse_args()
    rows = [orientation_row(*read(f), label) for f, label in a.state]
    if a.affine:
        rows += [orientation_row(*s) for s in affine_states(a.affine[0], float(a.affine[1]))]
    write_csv_atomic(a.csv, rows)
    for row in rows:
        print(f"{row['state']}: h/r_min axial {row['depth_axial']:.3f} lateral {row['depth_lateral']:.3f} (x{row['depth_ratio']:.2f}); "
              f"a/r_min > 0.9: axial {row['saturated_axial']:.3f} lateral {row['saturated_lateral']:.3f}")


if __name__ == "__main__":
    main()
