#!/usr/bin/env python3
"""Simple cubic lattice of overlapping spheres (spacing 1, radius r): the conductivity along z of
the union of the spheres (tools/voxel_conductivity.py on one cell; its faces are symmetry planes,
so the cell is exact), against the sintered-neck networks on the same lattice: the particle-centred
chain (two FE hemispheres per link, sintering-electrical.md §2.4) and the sphere element with caps
of the neck's rim (asin a/r) or of its area (2 asin a/2r), both evaluated here independently of the
engine (scipy Legendre polynomials). Necks: constant volume, capped by the grain-boundary-fraction
correction for six equal necks. This is the test that chose the element's cap rule (issue 21);
it uses no measured sample. Writes sc_lattice.csv beside this script.
Usage: sc_lattice.py   (about 1 min)
"""
import csv
import os
import numpy as np
from tools import voxel_conductivity as vc
from scipy.special import eval_legendre
# SC cell: spacing 1, sphere radius r at centre (0.5,0.5,0.5); neighbours' spheres reach in too (periodic)
def voxel_sc(r, n=120):
    h=1.0/n
    x=[]; rr=[]
    for i in (-1,0,1):
      for j in (-1,0,1):
        for k in (-1,0,1):
          x.append([0.5+i,0.5+j,0.5+k]); rr.append(r)
    x=np.array(x); rr=np.array(rr)
    solid = vc.voxelise(x, rr, np.zeros(3), np.array([n,n,n]), h) > 0
    # Dirichlet on the first/last voxel layers: planes at h/2 and 1-h/2
    I,info=vc.solve(solid,h,1e-8)
    L=(n-1)*h
    k=I*h*L/1.0
    # correct the layer offset: the cell length between the symmetry planes is 1, the solve spans L
    return k, 1-solid.mean()
def cv_radius(r, h):
    # equal spheres: solve collar volume = cap volume (sintering-electrical §2.5)
    D=2*r-h; d=D/2; c=r-d
    Vcap=2*np.pi/3*c*c*(3*r-c)
    def col(a):
        z=np.sqrt(max(r*r-a*a,0)); return 2*(np.pi*a*a*(d-z)-np.pi*(r*r*(d-z)-(d**3-z**3)/3))
    lo=np.sqrt(r*r-d*d); hi=r
    for _ in range(100):
        m=0.5*(lo+hi)
        if col(m)<Vcap: lo=m
        else: hi=m
    return 0.5*(lo+hi)
FEX=[0.05,0.10,0.15,0.20,0.30,0.40,0.50,0.60,0.70,0.80,0.90,0.95,0.99]
FEK=[0.059,0.113,0.166,0.216,0.316,0.418,0.525,0.642,0.775,0.936,1.149,1.293,1.449]
def beta(l,al):
    c=np.cos(al); return (eval_legendre(l-1,c)-eval_legendre(l+1,c))/((2*l+1)*(1-c))
def dropped_over_exact(al, L=2000):
    """The six-cap element (equal caps alpha on +-x, +-y, +-z): top-bottom conductance with the
    element's positive off-diagonal entries (negative conductances) dropped, over the exact one."""
    dirs = np.array([[0,0,1],[0,0,-1],[1,0,0],[-1,0,0],[0,1,0],[0,-1,0]], float)
    ls = np.arange(1, L + 1); b = beta(ls, al)
    Hm = np.array([[np.sum((2*ls+1)/ls*b*b*eval_legendre(ls, dirs[p] @ dirs[q]))/(4*np.pi) for q in range(6)] for p in range(6)])
    P = np.eye(6) - 1/6
    K = np.linalg.pinv(P @ Hm @ P)
    exact = 1/(Hm[0,0] + Hm[1,1] - 2*Hm[0,1])
    Kc = K.copy(); off = ~np.eye(6, dtype=bool); Kc[off & (Kc > 0)] = 0
    np.fill_diagonal(Kc, 0); np.fill_diagonal(Kc, -Kc.sum(1))
    free = [2,3,4,5]; V = np.zeros(6); V[0] = 1
    V[free] = np.linalg.solve(Kc[np.ix_(free, free)], -Kc[np.ix_(free, [0, 1])] @ V[[0, 1]])
    return (Kc[0] @ V) / exact
def H(al1,al2,cosg,L=3000):
    s=0
    for l in range(1,L+1):
        s+=(2*l+1)/l*beta(l,al1)*beta(l,al2)*eval_legendre(l,cosg)
    return s/(4*np.pi)
rows = []
for r in [0.52,0.55,0.6,0.65,0.7]:
    h=2*r-1  # overlap of neighbours at spacing 1
    kv,p=voxel_sc(r)
    a=cv_radius(r,h)
    a=min(a, r*np.sqrt(4/6)*1.0) if 6*a*a>4*r*r else a  # GBF cap for 6 equal necks
    Ki=np.pi*r*np.interp(a/r,FEX,FEK)  # kappa=1
    k_pc=(Ki/2)*1/1  # chain link conductance over cell area 1, length 1
    out=[]
    for name,al in [('asin',np.arcsin(min(a/r,1))),('area',2*np.arcsin(a/(2*r)))]:
        R=(2*H(al,al,1.0)-2*H(al,al,-1.0))/r
        out.append((name,1/R))
    hs=2*(1-p)/(2+p)
    rows.append(dict(radius=r, overlap_over_r=h/r, neck_over_r=a/r, porosity_union=p, hs_union=2*(1-p)/(2+p), kappa_voxel_union=kv,
                     kappa_particle_centred=k_pc, kappa_element_rim=out[0][1], kappa_element_area=out[1][1],
                     element_area_negatives_dropped_over_kept=dropped_over_exact(2*np.arcsin(a/(2*r)))))
    print(f"r={r} h/r={h/r:.3f} a/r={a/r:.3f} voxel_p={p:.3f} HS={hs:.3f} voxel_k={kv:.4f} particle_centred={k_pc:.4f} "+" ".join(f"se_{n}={k:.4f}" for n,k in out))
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "sc_lattice.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
