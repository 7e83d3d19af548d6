#!/usr/bin/env python3
r"""Independent axisymmetric finite-element reference: two rigid touching spheres in a
thermally expanding elastic matrix, tied to the matrix by a penalty (Robin) interface.

Problem (linear thermoelasticity, per unit eigenstrain, eps0 = 1, lengths in R, moduli in E)
---------------------------------------------------------------------------------------
Two rigid, non-expanding spheres of radius R, centres (0, 0, +-R), touching at the origin,
inside a matrix ball |x| <= b.  Matrix: isotropic (E, nu; lambda, mu, K = lambda + 2 mu / 3),
eigenstrain eps_th = eps0 I, sigma = C : (eps(u) - eps0 I) = C : eps(u) - 3 K eps0 I.
Total potential energy, minimised over the matrix field u and the sphere translations U_I:

  Pi(u, U) = 1/2 int_Omega (eps(u) - eps0 I) : C : (eps(u) - eps0 I) dV
             + alpha/2 sum_I int_{dS_I} |u - U_I e_z|^2 dS

Euler-Lagrange: div sigma = 0 in Omega; sigma.n = 0 on |x| = b; on a sphere surface (n the
outward normal of the matrix) sigma.n = -alpha (u - U_I e_z); force balance of each sphere
alpha int_{dS_I} (u_z - U_I) dS = 0.  alpha = inf: perfect bond, u = U_I e_z on dS_I.
Output q = U / (eps0 R) = (change of centre distance) / (eps0 D), D = 2R, U = U_upper.

Reduction: axisymmetric, torsion-free, u = (u_r(r, z), u_z(r, z)); by the z -> -z symmetry
only the quarter meridian r >= 0, z >= 0 is solved: u_r = 0 on r = 0, u_z = 0 on z = 0,
upper sphere (centre (0, R)) removed with the penalty to the single unknown U on its surface,
traction-free on r^2 + z^2 = b^2.  Strains (eps_rr, eps_zz, eps_tt, gamma_rz) =
(du_r/dr, du_z/dz, u_r/r, du_r/dz + du_z/dr); dV = 2 pi r dr dz; dS = 2 pi r ds.
Discrete system (symmetric positive definite, U is one extra unknown in the same matrix):
  K_ab = int B_a^T D B_b dV + alpha int N_a N_b dS (u_r-u_r and u_z-u_z blocks),
  K_{a,U} = -alpha int N_a dS (u_z rows),  K_UU = alpha int dS,
  f_a = int B_a^T D (1, 1, 1, 0)^T eps0 dV = 3 K eps0 int B_a^T (1, 1, 1, 0)^T dV.
alpha = inf is implemented exactly (no large penalty): u_r = 0 on the sphere and every sphere
node's u_z equation is merged into the U equation (u_z = U).

Elements: isoparametric 9-node Lagrange quadrilaterals (Q9), 3x3 Gauss points in the area,
4 Gauss points on the penalty edges; assembly vectorised with numpy, scipy.sparse direct solve
(SuperLU, splu).

Mesh (two spheres): inversion about the contact point, x' = c^2 x / |x|^2 with c^2 = 2R.
It maps the sphere |x - R e_z| = R to the plane z' = 1, the plane z = 0 to itself, the axis to
itself, the outer sphere |x| = b to the sphere |x'| = rho0 = 2R/b, and the contact point to
r' = infinity.  The inverted half-domain is the slab 0 <= z' <= 1, r' >= 0 minus the quarter
disc |x'| < rho0.  It is cut at r' = L = 2R / r_cut (the tiny lens of matrix between the sphere
and the plane within ~ r_cut of the contact point is dropped; its cut face is traction-free;
the effect of r_cut is studied separately with --rcut-study) and covered by two structured
blocks of Q9 elements:
  block A (polar): angle theta in [0, pi/2] uniform (n_t elements, n_t even), along each ray
    rho = rho0 (rho_out(theta) / rho0)^t, t in [0, 1] uniform (n_p elements), rho_out the
    distance to the square [0,1]^2 edge (r' = 1 for theta < pi/4, z' = 1 above).  Rays through
    the centre of inversion map to rays from the contact point, circles to circles: block A
    is, physically, a polar grid about the contact point between the outer sphere and the
    upper half of the particle, graded geometrically in |x|.
  block B (gap): r' = L^s, s in [0, 1] uniform (n_B elements, i.e. geometric grading in r',
    which is geometric grading towards the contact point in physical r ~ 2R / r'), and
    z' = tan(theta_k), theta_k in [0, pi/4] (the same lattice as block A's r' = 1 edge):
    n_t / 2 elements across the gap at every r, so the elements are always thinner than the
    local gap h(r) ~ r^2 / (2R) (thickness h / (n_t / 2), radial length ~ (dlog r') r).
Every lattice point including the mid-side and centre nodes is generated on the structured
grid in the inverted plane and mapped back node by node with x = 2R x' / |x'|^2, so the
particle, the symmetry plane and the outer sphere are exact at all nodes (curved boundaries
represented to second order).  Level l: n_t = 2^(l+1), n_p = ceil(n_t log(sqrt2/rho0)/(pi/2)),
n_B = ceil(n_t log(L) / (pi/2)) (radial element size ~ angular element size).

Verification (--single): one rigid sphere of radius a centred in a ball of radius b, quarter
meridian with z = 0 as symmetry plane, polar Q9 grid (theta uniform, rho geometric), sphere
fixed (U = 0), same penalty.  Closed form u = (A rho + B / rho^2) e_rho with
sigma_rr = 3K (A - 1) - 4 mu B / rho^3, sigma_rr(b) = 0, sigma_rr(a) = alpha u(a)
(alpha = inf: u(a) = 0).  Patch test: alpha = 0 (free cavity) on both meshes must give
u = eps0 x to round-off.

Usage:
  python3 tools/two_sphere_reference.py --nu 0.35 --alpha-R-over-E 10 --b-over-R 5 --levels 4
  python3 tools/two_sphere_reference.py --nu 0.35 --alpha-R-over-E inf --b-over-R 5 --levels 5
  python3 tools/two_sphere_reference.py --single
  python3 tools/two_sphere_reference.py --nu 0.35 --alpha-R-over-E 10 --rcut-study 1e-2,1e-3,1e-4
  python3 tools/two_sphere_reference.py --nu 0.35 --b-over-R 5 --levels 4 --log-check
Rows are merged into benchmarks/cpc_percolation/two_sphere_reference.csv (same key replaced).
"""
import argparse
import csv
import math
import os
import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = os.path.dirname(os.path.abspath(__file__))
CSV_DEFAULT = os.path.join(HERE, '..', 'benchmarks', 'cpc_percolation', 'two_sphere_reference.csv')
CSV_COLS = ['nu', 'alpha_R_over_E', 'b_over_R', 'level', 'elements', 'dofs', 'q',
            'change_from_previous_level', 'solve_seconds', 'r_cut_over_R']

# ----------------------------------------------------------------------------- Q9 element
_P1 = np.array([-1.0, 0.0, 1.0])


def _lag1(x):
    """1D quadratic Lagrange basis at nodes -1, 0, 1 and derivatives; x array -> (n,3)."""
    x = np.asarray(x, float)
    N = np.stack([0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)], axis=-1)
    dN = np.stack([x - 0.5, -2.0 * x, x + 0.5], axis=-1)
    return N, dN


# local node k = 3*di + dj  <->  lattice offset (di, dj), (xi, eta) = (di - 1, dj - 1)
_LOC = [(di, dj) for di in range(3) for dj in range(3)]


def _q9_gauss(ng=3):
    g, w = np.polynomial.legendre.leggauss(ng)
    Nx, dNx = _lag1(g)
    N = np.zeros((ng * ng, 9)); dN = np.zeros((ng * ng, 9, 2)); W = np.zeros(ng * ng)
    p = 0
    for a in range(ng):
        for b in range(ng):
            for k, (di, dj) in enumerate(_LOC):
                N[p, k] = Nx[a, di] * Nx[b, dj]
                dN[p, k, 0] = dNx[a, di] * Nx[b, dj]
                dN[p, k, 1] = Nx[a, di] * dNx[b, dj]
            W[p] = w[a] * w[b]
            p += 1
    return N, dN, W


class Mesh:
    """Q9 mesh made of structured blocks.  X (nn,2) = (r, z); elems (ne, 9); edges dict of
    (m,3) node triples; nodesets dict of node-index arrays."""

    def __init__(self):
        self.X = np.zeros((0, 2)); self.blocks = []; self.elems = []
        self.edges = {}; self.nodesets = {}

    def add_block(self, P, ids=None):
        """P: (2n+1, 2m+1, 2) lattice coordinates; ids: same-shape int array with -1 where a
        new node is to be created, otherwise an existing node index (shared interface)."""
        shp = P.shape[:2]
        if ids is None:
            ids = -np.ones(shp, int)
        ids = ids.copy()
        new = ids < 0
        nnew = int(new.sum())
        ids[new] = len(self.X) + np.arange(nnew)
        self.X = np.vstack([self.X, P[new]])
        n, m = (shp[0] - 1) // 2, (shp[1] - 1) // 2
        el = np.zeros((n * m, 9), int)
        for k, (di, dj) in enumerate(_LOC):
            el[:, k] = ids[di:di + 2 * n:2, dj:dj + 2 * m:2].reshape(-1)
        self.elems.append(el)
        return ids

    @staticmethod
    def edge_list(line):
        """node ids along a lattice line (2k+1 entries) -> (k,3) edges."""
        line = np.asarray(line)
        k = (len(line) - 1) // 2
        return np.stack([line[0:2 * k:2], line[1:2 * k + 1:2], line[2:2 * k + 1:2]], axis=1)

    def finish(self):
        self.E = np.vstack(self.elems)
        return self


def two_sphere_mesh(b_over_R, level, r_cut, R=1.0):
    nt = 2 ** (level + 1)
    rho0 = 2.0 * R / b_over_R
    Lr = 2.0 * R / r_cut
    npr = int(math.ceil(nt * math.log(math.sqrt(2.0) / rho0) / (math.pi / 2)))
    nB = int(math.ceil(nt * math.log(Lr) / (math.pi / 2)))
    th = np.linspace(0.0, math.pi / 2, 2 * nt + 1)
    t = np.linspace(0.0, 1.0, 2 * npr + 1)
    c, s = np.cos(th), np.sin(th)
    c[-1] = 0.0; s[0] = 0.0
    rho_out = np.where(th <= math.pi / 4 + 1e-15, 1.0 / np.maximum(c, 1e-300), 1.0 / np.maximum(s, 1e-300))
    rho = rho0 * (rho_out[:, None] / rho0) ** t[None, :]
    PA = np.stack([rho * c[:, None], rho * s[:, None]], axis=-1)
    # exact square edges at t = 1
    PA[:nt + 1, -1, 0] = 1.0; PA[:nt + 1, -1, 1] = np.tan(th[:nt + 1]); PA[nt, -1, 1] = 1.0
    PA[nt:, -1, 1] = 1.0; PA[nt:, -1, 0] = c[nt:] / s[nt:]; PA[nt, -1, 0] = 1.0
    sB = np.linspace(0.0, 1.0, 2 * nB + 1)
    rp = Lr ** sB; rp[0] = 1.0
    zp = np.tan(th[:nt + 1]); zp[-1] = 1.0
    PB = np.stack(np.broadcast_arrays(rp[:, None], zp[None, :]), axis=-1).astype(float)

    def phys(P):
        q2 = (P ** 2).sum(-1, keepdims=True)
        return 2.0 * R * P / q2

    m = Mesh()
    idA = m.add_block(phys(PA))
    idsB = -np.ones(PB.shape[:2], int)
    idsB[0, :] = idA[:nt + 1, -1]
    idB = m.add_block(phys(PB), idsB)
    m.finish()
    sphere_lines = [idA[nt:, -1], idB[:, -1]]
    m.edges['sphere'] = np.vstack([Mesh.edge_list(l) for l in sphere_lines])
    m.nodesets['sphere'] = np.unique(np.concatenate(sphere_lines))
    m.nodesets['axis'] = idA[-1, :]
    m.nodesets['sym'] = np.unique(np.concatenate([idA[0, :], idB[:, 0]]))
    m.nodesets['outer'] = idA[:, 0]
    # snap: exact zeros on the axis and the plane, exact radius b on the outer sphere
    m.X[m.nodesets['axis'], 0] = 0.0
    m.X[m.nodesets['sym'], 1] = 0.0
    m.info = dict(n_theta=nt, n_rho=npr, n_B=nB, n_gap=nt // 2)
    return m


def single_sphere_mesh(a, b, level):
    nt = 2 ** (level + 1)
    npr = int(math.ceil(nt * math.log(b / a) / (math.pi / 2)))
    th = np.linspace(0.0, math.pi / 2, 2 * nt + 1)
    rho = a * (b / a) ** np.linspace(0.0, 1.0, 2 * npr + 1)
    c, s = np.cos(th), np.sin(th)
    c[-1] = 0.0; s[0] = 0.0
    P = np.stack([c[:, None] * rho[None, :], s[:, None] * rho[None, :]], axis=-1)
    m = Mesh()
    ids = m.add_block(P)
    m.finish()
    m.edges['sphere'] = Mesh.edge_list(ids[:, 0])
    m.nodesets['sphere'] = ids[:, 0]
    m.nodesets['axis'] = ids[-1, :]
    m.nodesets['sym'] = ids[0, :]
    m.nodesets['outer'] = ids[:, -1]
    m.info = dict(n_theta=nt, n_rho=npr)
    return m


# ----------------------------------------------------------------------------- assembly
def elastic(nu, E=1.0):
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    K = lam + 2 * mu / 3
    return lam, mu, K


def assemble_volume(m, nu, eps0=1.0, chunk=4000):
    lam, mu, K = elastic(nu)
    D = np.array([[lam + 2 * mu, lam, lam, 0], [lam, lam + 2 * mu, lam, 0],
                  [lam, lam, lam + 2 * mu, 0], [0, 0, 0, mu]])
    sig_th = D @ np.array([1.0, 1.0, 1.0, 0.0]) * eps0
    N, dN, W = _q9_gauss(3)
    E = m.E
    ne = len(E)
    rows, cols, vals = [], [], []
    f = np.zeros(2 * len(m.X))
    dof = np.empty((ne, 18), int)
    dof[:, 0::2] = 2 * E; dof[:, 1::2] = 2 * E + 1
    signs = []
    for e0 in range(0, ne, chunk):
        sl = slice(e0, min(ne, e0 + chunk))
        X = m.X[E[sl]]                                       # (c,9,2)
        J = np.einsum('eai,gak->egik', X, dN)                # dx_i/dxi_k
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        signs.append(np.sign(det))
        inv = np.empty_like(J)
        inv[..., 0, 0] = J[..., 1, 1] / det; inv[..., 1, 1] = J[..., 0, 0] / det
        inv[..., 0, 1] = -J[..., 0, 1] / det; inv[..., 1, 0] = -J[..., 1, 0] / det
        dNx = np.einsum('gak,egki->egai', dN, inv)           # (c,g,9,2)
        r = np.einsum('ga,ea->eg', N, X[..., 0])
        wt = 2 * math.pi * r * np.abs(det) * W[None, :]
        c = X.shape[0]; ng = len(W)
        B = np.zeros((c, ng, 4, 18))
        B[:, :, 0, 0::2] = dNx[..., 0]
        B[:, :, 1, 1::2] = dNx[..., 1]
        B[:, :, 2, 0::2] = N[None, :, :] / r[:, :, None]
        B[:, :, 3, 0::2] = dNx[..., 1]
        B[:, :, 3, 1::2] = dNx[..., 0]
        Ke = np.einsum('egsa,st,egtb,eg->eab', B, D, B, wt)
        fe = np.einsum('egsa,s,eg->ea', B, sig_th, wt)
        d = dof[sl]
        rows.append(np.repeat(d, 18, axis=1).reshape(-1))
        cols.append(np.tile(d, (1, 18)).reshape(-1))
        vals.append(Ke.reshape(-1))
        np.add.at(f, d.reshape(-1), fe.reshape(-1))
    sg = np.concatenate(signs)
    if not (np.all(sg > 0) or np.all(sg < 0)):
        # blocks may have opposite orientation; each element must be non-degenerate
        assert np.all(sg != 0)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), f


def assemble_penalty(m, alpha, iU):
    """alpha int |u - U e_z|^2 dS on the 'sphere' edges (iU < 0: U fixed at 0)."""
    g, w = np.polynomial.legendre.leggauss(4)
    Nl, dNl = _lag1(g)
    ed = m.edges['sphere']
    X = m.X[ed]                                              # (m,3,2)
    t = np.einsum('ga,eai->egi', dNl, X)
    ds = np.sqrt((t ** 2).sum(-1))
    r = np.einsum('ga,ea->eg', Nl, X[..., 0])
    wt = alpha * 2 * math.pi * r * ds * w[None, :]
    M = np.einsum('ga,gb,eg->eab', Nl, Nl, wt)               # (m,3,3)
    cvec = np.einsum('ga,eg->ea', Nl, wt)
    rows, cols, vals = [], [], []
    for comp in (0, 1):
        d = 2 * ed + comp
        rows.append(np.repeat(d, 3, axis=1).reshape(-1))
        cols.append(np.tile(d, (1, 3)).reshape(-1))
        vals.append(M.reshape(-1))
    if iU >= 0:
        d = (2 * ed + 1).reshape(-1)
        rows += [d, np.full_like(d, iU), np.array([iU])]
        cols += [np.full_like(d, iU), d, np.array([iU])]
        vals += [-cvec.reshape(-1), -cvec.reshape(-1), np.array([wt.sum()])]
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)


def solve(m, nu, alpha, with_U=True, eps0=1.0, load_U=0.0):
    """Returns (u (nn,2), U, ndof_eq, solve_seconds).  load_U: external force on U."""
    nn = len(m.X)
    nraw = 2 * nn + 1
    iU = 2 * nn
    r1, c1, v1, f1 = assemble_volume(m, nu, eps0)
    f = np.zeros(nraw); f[:2 * nn] = f1; f[iU] = load_U
    fixed = np.zeros(nraw, bool)
    fixed[2 * m.nodesets['axis']] = True
    fixed[2 * m.nodesets['sym'] + 1] = True
    if not with_U or alpha == 0.0:
        fixed[iU] = True
    merge = np.arange(nraw)
    rows, cols, vals = [r1], [c1], [v1]
    if math.isinf(alpha):
        sn = m.nodesets['sphere']
        fixed[2 * sn] = True
        if fixed[iU]:
            fixed[2 * sn + 1] = True
        else:
            merge[2 * sn + 1] = iU
    elif alpha > 0:
        r2, c2, v2 = assemble_penalty(m, alpha, -1 if fixed[iU] else iU)
        rows.append(r2); cols.append(c2); vals.append(v2)
    # equation numbers
    rep = merge.copy()
    keep = ~fixed & (rep == np.arange(nraw))
    eq_of = -np.ones(nraw, int)
    eq_of[keep] = np.arange(keep.sum())
    eq = eq_of[rep]
    eq[fixed] = -1
    neq = int(keep.sum())
    R = np.concatenate(rows); C = np.concatenate(cols); V = np.concatenate(vals)
    R = eq[R]; C = eq[C]
    ok = (R >= 0) & (C >= 0)
    Kmat = sp.csc_matrix((V[ok], (R[ok], C[ok])), shape=(neq, neq))
    Kmat.sum_duplicates()
    F = np.zeros(neq)
    okf = eq >= 0
    np.add.at(F, eq[okf], f[okf])
    t0 = time.time()
    lu = spla.splu(Kmat, permc_spec='MMD_AT_PLUS_A', options=dict(SymmetricMode=True))
    x = lu.solve(F)
    tsol = time.time() - t0
    full = np.zeros(nraw)
    full[okf] = x[eq[okf]]
    u = full[:2 * nn].reshape(nn, 2)
    return u, full[iU], neq, tsol


# ----------------------------------------------------------------------------- CSV
def merge_csv(path, newrows):
    key = lambda d: (float(d['nu']), str(d['alpha_R_over_E']), float(d['b_over_R']),
                     int(d['level']), float(d['r_cut_over_R']))
    old = []
    if os.path.exists(path):
        with open(path) as fh:
            old = list(csv.DictReader(fh))
    keys = {key(d) for d in newrows}
    rows = [d for d in old if key(d) not in keys] + newrows

    def sk(d):
        a = str(d['alpha_R_over_E']); af = float('inf') if a == 'inf' else float(a)
        return (float(d['nu']), af, float(d['b_over_R']), -float(d['r_cut_over_R']), int(d['level']))
    rows.sort(key=sk)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, 'w', newline='') as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_COLS)
        w.writeheader()
        for d in rows:
            w.writerow({k: d.get(k, '') for k in CSV_COLS})


def fmt_alpha(a):
    return 'inf' if math.isinf(a) else ('%g' % a)


# ----------------------------------------------------------------------------- drivers
def run_two_sphere(nu, alpha, b_over_R, levels, r_cut, first_level=1, quiet=False):
    out = []
    prev = None
    for lv in range(first_level, levels + 1):
        t0 = time.time()
        m = two_sphere_mesh(b_over_R, lv, r_cut)
        u, U, neq, ts = solve(m, nu, alpha)
        q = U  # R = eps0 = 1
        ch = '' if prev is None else '%.3e' % ((q - prev) / abs(q))
        row = dict(nu='%g' % nu, alpha_R_over_E=fmt_alpha(alpha), b_over_R='%g' % b_over_R,
                   level=lv, elements=len(m.E), dofs=neq, q='%.8f' % q,
                   change_from_previous_level=ch, solve_seconds='%.2f' % ts,
                   r_cut_over_R='%g' % r_cut)
        out.append(row)
        if not quiet:
            print('nu=%g alphaR/E=%s b/R=%g r_cut/R=%g level=%d (n_theta=%d n_rho=%d n_B=%d, %d across gap) '
                  'elements=%d dofs=%d q=%.8f change=%s solve=%.2fs total=%.2fs' %
                  (nu, fmt_alpha(alpha), b_over_R, r_cut, lv, m.info['n_theta'], m.info['n_rho'],
                   m.info['n_B'], m.info['n_gap'], len(m.E), neq, q, ch or '-', ts, time.time() - t0),
                  flush=True)
        prev = q
    return out


def single_exact(nu, alpha, a, b, eps0=1.0):
    lam, mu, K = elastic(nu)
    # unknowns A, B ; sigma(rho) = 3K(A - eps0) - 4 mu B / rho^3
    if math.isinf(alpha):
        M = np.array([[3 * K, -4 * mu / b ** 3], [a, 1.0 / a ** 2]])
        rhs = np.array([3 * K * eps0, 0.0])
    else:
        M = np.array([[3 * K, -4 * mu / b ** 3],
                      [3 * K - alpha * a, -4 * mu / a ** 3 - alpha / a ** 2]])
        rhs = np.array([3 * K * eps0, 3 * K * eps0])
    A, B = np.linalg.solve(M, rhs)
    return A, B


def run_single(nu, alphas, b, levels, a=1.0):
    print('== single sphere verification: a = %g, b = %g, nu = %g (U fixed at 0) ==' % (a, b, nu))
    res = {}
    for alpha in alphas:
        A, B = single_exact(nu, alpha, a, b)
        prev = None
        for lv in range(1, levels + 1):
            m = single_sphere_mesh(a, b, lv)
            u, U, neq, ts = solve(m, nu, alpha, with_U=False)
            rho = np.sqrt((m.X ** 2).sum(1))
            er = m.X / rho[:, None]
            uex = (A * rho + B / rho ** 2)[:, None] * er
            err_all = np.abs(u - uex).max() / np.abs(uex).max()
            # along the 45-degree ray (radial component)
            ray = np.abs(np.arctan2(m.X[:, 1], m.X[:, 0]) - math.pi / 4) < 1e-12
            ur = (u[ray] * er[ray]).sum(1)
            err_ray = np.abs(ur - (A * rho[ray] + B / rho[ray] ** 2)).max() / np.abs(uex).max()
            rate = '' if prev is None else '%.2f' % math.log2(prev / err_all)
            print('alphaR/E=%-5s level=%d n_theta=%3d n_rho=%3d dofs=%6d  max rel err |u| (all nodes)=%.3e'
                  '  u_r on 45deg ray=%.3e  rate=%s  [exact u(a)=%.6f u(b)=%.6f]' %
                  (fmt_alpha(alpha), lv, m.info['n_theta'], m.info['n_rho'], neq, err_all, err_ray,
                   rate or '-', A * a + B / a ** 2, A * b + B / b ** 2), flush=True)
            res[(alpha, lv)] = (err_all, err_ray)
            prev = err_all
    print('== patch tests (alpha = 0, stress-free cavity): exact u = eps0 x ==')
    for lv in (1, 3):
        m = single_sphere_mesh(a, b, lv)
        u, U, neq, ts = solve(m, nu, 0.0, with_U=False)
        print('single-sphere mesh level %d: max |u - x| / b = %.2e' % (lv, np.abs(u - m.X).max() / b))
        for bR in (5.0, 20.0):
            m = two_sphere_mesh(bR, lv, 1e-5)
            u, U, neq, ts = solve(m, nu, 0.0, with_U=False)
            print('two-sphere cusp mesh b/R=%g r_cut=1e-5 level %d: max |u - x| / b = %.2e, '
                  'max rel |u - x| / |x| = %.2e' %
                  (bR, lv, np.abs(u - m.X).max() / bR,
                   (np.sqrt(((u - m.X) ** 2).sum(1)) / np.sqrt((m.X ** 2).sum(1))).max()))
    return res


def run_log_check(nu, b_over_R, level, cuts):
    """alpha = inf: stiffness k(r_cut) = 1/U for a unit force on U with eps0 = 0, and blocked
    force F = q k.  Thin-gap asymptotics: dk/dln(R/r_cut) -> 4 pi M R (M = lambda + 2 mu),
    since the gap h = r^2/(2R) under a bonded relative displacement U carries sigma_zz = M U/h."""
    lam, mu, K = elastic(nu)
    M = lam + 2 * mu
    print('== alpha = inf log check: nu=%g b/R=%g level=%d; thin-gap prediction dk/dln(R/r_cut) = 4 pi M R = %.5f E R'
          % (nu, b_over_R, level, 4 * math.pi * M))
    prev = None
    for rc in cuts:
        m = two_sphere_mesh(b_over_R, level, rc)
        _, U1, _, _ = solve(m, nu, float('inf'), eps0=0.0, load_U=1.0)
        _, q, _, _ = solve(m, nu, float('inf'))
        k = 1.0 / U1
        sl = '' if prev is None else '%.5f' % ((k - prev[1]) / math.log(prev[0] / rc))
        print('r_cut/R=%-7g k/(E R)=%.6f  blocked force F/(E eps0 R^2)=q k=%.6f  q=%.6f  dk/dln(R/r_cut)=%s'
              % (rc, k, q * k, q, sl or '-'), flush=True)
        prev = (rc, k)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--nu', type=float, default=0.35)
    ap.add_argument('--alpha-R-over-E', default='10')
    ap.add_argument('--b-over-R', type=float, default=5.0)
    ap.add_argument('--levels', type=int, default=4)
    ap.add_argument('--first-level', type=int, default=1)
    ap.add_argument('--r-cut', type=float, default=1e-5,
                    help='cusp truncation radius r_cut/R (default 1e-5)')
    ap.add_argument('--rcut-study', default='',
                    help='comma list of r_cut/R values: run each at --levels only (plus level-1)')
    ap.add_argument('--log-check', action='store_true',
                    help='alpha=inf: stiffness vs r_cut against the thin-gap log asymptotics')
    ap.add_argument('--single', action='store_true', help='single-sphere verification + patch tests')
    ap.add_argument('--csv', default=CSV_DEFAULT)
    ap.add_argument('--no-csv', action='store_true')
    a = ap.parse_args()
    if a.single:
        run_single(a.nu, [10.0, 100.0, float('inf')], a.b_over_R, a.levels)
        return
    if a.log_check:
        run_log_check(a.nu, a.b_over_R, a.levels, [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-8, 1e-10])
        return
    alpha = float('inf') if a.alpha_R_over_E.lower() in ('inf', 'infinity') else float(a.alpha_R_over_E)
    rows = []
    if a.rcut_study:
        for rc in [float(x) for x in a.rcut_study.split(',')]:
            rows += run_two_sphere(a.nu, alpha, a.b_over_R, a.levels, rc, first_level=a.levels - 1)
    else:
        rows = run_two_sphere(a.nu, alpha, a.b_over_R, a.levels, a.r_cut, first_level=a.first_level)
    if not a.no_csv:
        merge_csv(a.csv, rows)
        print('wrote', os.path.normpath(a.csv))


if __name__ == '__main__':
    main()
