#!/usr/bin/env python3
"""Continuum reference for a network's effective conductivity: the union of a snapshot's spheres
voxelised and Laplace's equation solved on it (finite volumes), with no network model at all.

Why: a resistor network on particle centres (seed 000) is a model of the sintered body; this tool
solves the body itself -- the same spheres, the union of their volumes, conductivity kappa inside
and 0 in the pores -- so that the network can be judged per snapshot against the geometry it was
built from (issue 21: the network exceeds the Hashin-Shtrikman bound; this reference cannot, as it
is a true two-phase continuum).

Method: voxel centres on a grid of spacing h; a voxel is solid when its centre lies in a sphere.
Neighbouring solid voxels (6-connectivity) are joined by the conductance kappa h (face h^2 over
distance h). Two electrodes: the solid voxels of the first and last layer along z, held at 1 and 0
(in the sample: the layers at the punches; in a box: its two z faces); every other face insulated.
Solid clusters that reach neither electrode, or only one, carry no current and are dropped. The
reduced system is solved by conjugate gradients (Jacobi preconditioner, start from the linear
profile) to a relative residual of --tol. kappa_eff / kappa = I L / (dV A), L = (nz - 1) h the
distance between the electrode layers, A the cross-section (the die's pi R^2 for the sample, the
box face for a box). The voxel porosity of the same region is reported beside it, with the
Hashin-Shtrikman upper bound 2 (1 - p) / (2 + p) at that porosity.

Error: first order in h at the solid surfaces (staircase); run two spacings (--voxel) and report
both (the tool prints the solve time and the unknowns).

Usage:
  voxel_conductivity.py SNAPSHOT.h5 [--voxel 0.4e-6] [--box whole|centre:SIDE_M] [--tol 1e-6]
      [--csv OUT.csv]
Reads /state/particles/{position,radius} and the walls bottom/top (planes) and die (cylinder).
"""
import argparse
import csv
import os
import sys
import time

import h5py
import numpy as np
import scipy.ndimage as ndi
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def read_snapshot(path):
    with h5py.File(path, "r") as f:
        x = f["state/particles/position"][()]
        r = f["state/particles/radius"][()]
        walls = {}
        for w in ("bottom", "top", "die"):
            g = f["state/walls/" + w]
            geo = g["geometry"][()][0]
            walls[w] = (geo, float(g["u"][()]))
    # Plane: point (0..2), normal (3..5), offset u along the normal; cylinder: radius at 6.
    z_bot = walls["bottom"][0][2] + walls["bottom"][1] * walls["bottom"][0][5]
    z_top = walls["top"][0][2] + walls["top"][1] * walls["top"][0][5]
    return x, r, z_bot, z_top, walls["die"][0][6]


def voxelise(x, r, lo, n, h, region=None):
    """Cover count (nx, ny, nz): how many spheres contain each voxel centre lo + (i + 1/2) h (only
    inside `region`, a boolean (nx, ny) mask, when given). The solid is cover > 0; cover.sum() is
    the voxel count of the spheres one by one (overlaps counted as often as they are covered: the
    mass of the spheres)."""
    cover = np.zeros(n, dtype=np.uint16)
    for c, rad in zip(x, r):
        i0 = np.maximum(np.floor((c - rad - lo) / h - 0.5).astype(int), 0)
        i1 = np.minimum(np.ceil((c + rad - lo) / h - 0.5).astype(int) + 1, n)
        if np.any(i1 <= i0):
            continue
        ax = [lo[k] + (np.arange(i0[k], i1[k]) + 0.5) * h - c[k] for k in range(3)]
        d2 = ax[0][:, None, None] ** 2 + ax[1][None, :, None] ** 2 + ax[2][None, None, :] ** 2
        inside = d2 <= rad * rad
        if region is not None:
            inside &= region[i0[0]:i1[0], i0[1]:i1[1], None]
        cover[i0[0]:i1[0], i0[1]:i1[1], i0[2]:i1[2]] += inside.astype(np.uint16)
    return cover


def inflate_to_mass(x, r, lo, n, h, region, counted):
    """Radius factor s >= 1 (bisection, 1e-4) whose union holds the spheres' mass: the union of
    the spheres s r_i covers as many voxels as the spheres r_i one by one (the lens volume of every
    overlap put back into the body, as the sintering law's constant-volume neck assumes)."""
    a, b = 1.0, 1.3
    while b - a > 1e-4:
        m = 0.5 * (a + b)
        covered = int((voxelise(x, m * r, lo, n, h, region) > 0).sum())
        (a, b) = (m, b) if covered < counted else (a, m)
    return 0.5 * (a + b)


def solve(solid, h, tol):
    """Potentials with layer 0 at 1 V and layer nz-1 at 0 V; returns (I [A per unit kappa], info)."""
    nz = solid.shape[2]
    lab, _ = ndi.label(solid)  # 6-connectivity
    top_ids = set(np.unique(lab[:, :, 0][solid[:, :, 0]]))
    bot_ids = set(np.unique(lab[:, :, nz - 1][solid[:, :, nz - 1]]))
    keep_ids = np.array(sorted((top_ids & bot_ids) - {0}), dtype=np.int64)
    active = np.isin(lab, keep_ids)
    fixed = np.zeros_like(active)
    fixed[:, :, 0] = active[:, :, 0]
    fixed[:, :, nz - 1] = active[:, :, nz - 1]
    free = active & ~fixed
    idx = -np.ones(solid.shape, dtype=np.int64)
    idx[free] = np.arange(free.sum())
    m = int(free.sum())
    zz = np.broadcast_to(np.arange(nz)[None, None, :], solid.shape)
    vfix = np.where(fixed, 1.0 - zz / (nz - 1), 0.0)
    rows, cols, diag, rhs = [], [], np.zeros(m), np.zeros(m)
    current = 0.0
    for axis in range(3):
        sl_a = [slice(None)] * 3
        sl_b = [slice(None)] * 3
        sl_a[axis] = slice(0, -1)
        sl_b[axis] = slice(1, None)
        a_act, b_act = active[tuple(sl_a)], active[tuple(sl_b)]
        link = a_act & b_act
        ia, ib = idx[tuple(sl_a)][link], idx[tuple(sl_b)][link]
        fa, fb = ia >= 0, ib >= 0
        both = fa & fb
        rows += [ia[both], ib[both]]
        cols += [ib[both], ia[both]]
        np.add.at(diag, ia[fa], 1.0)
        np.add.at(diag, ib[fb], 1.0)
        va, vb = vfix[tuple(sl_a)][link], vfix[tuple(sl_b)][link]
        np.add.at(rhs, ia[fa & ~fb], vb[fa & ~fb])
        np.add.at(rhs, ib[fb & ~fa], va[fb & ~fa])
    r_ = np.concatenate(rows)
    c_ = np.concatenate(cols)
    A = sp.csr_matrix((np.concatenate([-np.ones(len(r_)), diag]), (np.concatenate([r_, np.arange(m)]), np.concatenate([c_, np.arange(m)]))), shape=(m, m))
    x0 = (1.0 - zz / (nz - 1))[free]
    M = sp.diags(1.0 / diag)
    its = [0]

    def cb(_):
        its[0] += 1

    t0 = time.time()
    v, info = spla.cg(A, rhs, x0=x0, rtol=tol, maxiter=200000, M=M, callback=cb) if "rtol" in spla.cg.__code__.co_varnames else spla.cg(A, rhs, x0=x0, tol=tol, maxiter=200000, M=M, callback=cb)
    secs = time.time() - t0
    if info != 0:
        sys.exit(f"voxel_conductivity: CG did not converge (info {info})")
    V = vfix.copy()
    V[free] = v
    # Current leaving layer 0 into layer 1 and arriving in layer nz-1 from nz-2 (Eq. 31 check).
    l01 = active[:, :, 0] & active[:, :, 1]
    I_top = float(np.sum((V[:, :, 0] - V[:, :, 1])[l01]))
    l_end = active[:, :, nz - 2] & active[:, :, nz - 1]
    I_bot = float(np.sum((V[:, :, nz - 2] - V[:, :, nz - 1])[l_end]))
    return I_top, dict(unknowns=m, iterations=its[0], solve_s=secs, mismatch=abs(I_top - I_bot) / abs(I_top) if I_top else float("nan"))


def write_profiles(path, solid, cover, inside, lo, h, R_die):
    """Union and mass porosity in annuli of 2 um from the die wall inwards and in slabs of 5 um
    along z (the wall layers and the core of the sample)."""
    n = solid.shape
    xc = lo[0] + (np.arange(n[0]) + 0.5) * h
    yc = lo[1] + (np.arange(n[1]) + 0.5) * h
    rho = np.sqrt(xc[:, None] ** 2 + yc[None, :] ** 2)
    rows = []
    for k in range(int(R_die / 2e-6) + 1):
        ring = inside & (rho >= R_die - (k + 1) * 2e-6) & (rho < R_die - k * 2e-6)
        if ring.sum() == 0:
            continue
        m = np.broadcast_to(ring[:, :, None], n)
        rows.append(("radial", (k + 0.5) * 2e-6, 1.0 - solid[m].mean(), 1.0 - cover[m].mean()))
    zc = (np.arange(n[2]) + 0.5) * h
    for k in range(int(zc[-1] / 5e-6) + 1):
        sl = (zc >= k * 5e-6) & (zc < (k + 1) * 5e-6)
        if sl.sum() == 0:
            continue
        m = inside[:, :, None] & sl[None, None, :]
        rows.append(("axial", (k + 0.5) * 5e-6, 1.0 - solid[m].mean(), 1.0 - cover[m].mean()))
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["profile", "distance_from_wall_or_bottom_m", "porosity_union", "porosity_mass"])
        w.writerows(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("snapshot")
    ap.add_argument("--voxel", type=float, default=0.4e-6, help="voxel edge h [m]")
    ap.add_argument("--box", default="whole", help="whole (the sample in the die) or centre:SIDE_M (a cube at the sample centre)")
    ap.add_argument("--tol", type=float, default=1e-6, help="CG relative residual")
    ap.add_argument("--geometry", default="union", choices=["union", "mass"],
                    help="union: the spheres as they are (lens volumes lost); mass: radii scaled by one factor until the union holds the spheres' mass (porosity = the mass porosity)")
    ap.add_argument("--csv", help="append one row to this CSV")
    ap.add_argument("--no-solve", action="store_true", help="porosities (and profiles) only")
    ap.add_argument("--profiles", help="write the radial and axial profiles of the union and mass porosity (whole box) to this CSV")
    a = ap.parse_args()
    x, r, z_bot, z_top, R_die = read_snapshot(a.snapshot)
    h = a.voxel
    if a.box == "whole":
        lo = np.array([-R_die, -R_die, z_bot])
        hi = np.array([R_die, R_die, z_top])
    else:
        side = float(a.box.split(":")[1])
        c = np.array([0.0, 0.0, 0.5 * (z_bot + z_top)])
        lo, hi = c - 0.5 * side, c + 0.5 * side
    n = np.maximum(np.round((hi - lo) / h).astype(int), 2)
    t0 = time.time()
    if a.box == "whole":
        xc = lo[0] + (np.arange(n[0]) + 0.5) * h
        yc = lo[1] + (np.arange(n[1]) + 0.5) * h
        inside = (xc[:, None] ** 2 + yc[None, :] ** 2) <= R_die * R_die
        area = np.pi * R_die * R_die
        region_voxels = inside.sum() * n[2]
    else:
        inside = np.ones(n[:2], dtype=bool)
        area = (n[0] * h) * (n[1] * h)
        region_voxels = int(np.prod(n))
    cover = voxelise(x, r, lo, n, h, inside)
    solid = cover > 0
    counted = int(cover.sum(dtype=np.int64))
    porosity_mass = 1.0 - counted / region_voxels
    if a.profiles and a.box == "whole":
        write_profiles(a.profiles, solid, cover, inside, lo, h, R_die)
    scale = 1.0
    if a.geometry == "mass":
        scale = inflate_to_mass(x, r, lo, n, h, inside, counted)
        solid = voxelise(x, scale * r, lo, n, h, inside) > 0
    t_vox = time.time() - t0
    porosity = 1.0 - solid.sum() / region_voxels
    if a.no_solve:
        print(f"porosity_union={porosity:.6g} porosity_mass={porosity_mass:.6g} radius_scale={scale:.6g}")
        return
    I, info = solve(solid, h, a.tol)
    L = (n[2] - 1) * h
    k_rel = I * h * L / (1.0 * area)  # link conductance kappa h with kappa = 1, dV = 1
    hs = 2.0 * (1.0 - porosity) / (2.0 + porosity)
    row = dict(snapshot=os.path.basename(a.snapshot), box=a.box, geometry=a.geometry, radius_scale=scale, porosity_mass=porosity_mass, voxel_m=h, nx=n[0], ny=n[1], nz=n[2], porosity_voxel=porosity,
               kappa_rel=k_rel, hs_bound_rel=hs, kappa_over_hs=k_rel / hs, unknowns=info["unknowns"], cg_iterations=info["iterations"],
               current_mismatch=info["mismatch"], voxelise_s=t_vox, solve_s=info["solve_s"])
    print(" ".join(f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
    if a.csv:
        new = not os.path.exists(a.csv)
        with open(a.csv, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(row))
            if new:
                w.writeheader()
            w.writerow(row)


if __name__ == "__main__":
    main()
