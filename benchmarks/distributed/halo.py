#!/usr/bin/env python3
"""Halo cost of a spatial decomposition of a real compact (issue 24 item 4, docs/distributed.md).

usage: halo.py FINAL_STATE.h5 [--ranks 2,4,8,16,27,64] [--csv OUT.csv]

Reads the particles (position, radius) and the contact rows (i, j) of a sparkdem checkpoint, splits
the particles into P subdomains by recursive coordinate bisection on particle count (the cut
direction is the longest extent of the current box; equal halves up to one particle), and counts
for each P:
  ghosts        particles another rank needs: particle j is a ghost of rank q if its centre lies
                within r_j + r_max(q) + skin of the box of q's centres (the reach of a contact
                candidate; halo_width_m reports the largest, 2 r_max + skin)
  halo_fraction sum of ghosts over ranks / N
  cut_rows      contact rows whose two particles are on different ranks (computed twice, once per
                side, if each rank owns the rows of its particles) / all rows
  imbalance     largest rank's particle count / mean
Nothing here runs in parallel: it measures what a decomposition of this packing would exchange.
"""
import argparse
import csv
import os
import sys

import h5py
import numpy as np


def bisect(idx, pos, parts, out):
    """Recursive coordinate bisection of the particle indices idx into `parts` boxes."""
    if parts == 1:
        out.append(idx)
        return
    p = pos[idx]
    axis = int(np.argmax(p.max(axis=0) - p.min(axis=0)))
    order = idx[np.argsort(p[:, axis], kind="stable")]
    left_parts = parts // 2
    n_left = int(round(len(idx) * left_parts / parts))
    bisect(order[:n_left], pos, left_parts, out)
    bisect(order[n_left:], pos, parts - left_parts, out)


def measure(pos, radius, rows, skin, ranks):
    n = len(pos)
    parts = []
    bisect(np.arange(n), pos, ranks, parts)
    owner = np.empty(n, dtype=np.int64)
    for k, idx in enumerate(parts):
        owner[idx] = k
    w = 2.0 * radius.max() + skin
    ghosts = 0
    for k, idx in enumerate(parts):
        lo, hi = pos[idx].min(axis=0), pos[idx].max(axis=0)  # the box of the owned centres
        reach = (radius + radius[idx].max() + skin)[:, None]  # a candidate pair: d < r_j + r_i + skin
        near = np.all((pos >= lo - reach) & (pos <= hi + reach), axis=1) & (owner != k)
        ghosts += int(near.sum())
    cut = int((owner[rows[:, 0]] != owner[rows[:, 1]]).sum()) if len(rows) else 0
    sizes = np.array([len(p) for p in parts])
    return {"ranks": ranks, "particles": n, "per_rank": n / ranks, "halo_width_m": w, "ghosts": ghosts,
            "halo_fraction": ghosts / n, "rows": len(rows), "cut_rows": cut, "cut_row_fraction": cut / max(1, len(rows)),
            "imbalance": sizes.max() / sizes.mean()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("state")
    ap.add_argument("--ranks", default="2,4,8,16,27,64")
    ap.add_argument("--csv", default="")
    a = ap.parse_args()
    with h5py.File(a.state, "r") as f:
        pos = f["state/particles/position"][...]
        radius = f["state/particles/radius"][...]
        rows = np.stack([f["state/contacts/i"][...], f["state/contacts/j"][...]], axis=1).astype(np.int64)
        skin = float(f["state/stage_skin"][()]) if "state/stage_skin" in f else 0.0
    out = [measure(pos, radius, rows, skin, int(p)) for p in a.ranks.split(",")]
    keys = list(out[0])
    print(",".join(keys))
    for r in out:
        print(",".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k]) for k in keys))
    if a.csv:
        tmp = a.csv + ".tmp"
        with open(tmp, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=keys)
            wr.writeheader()
            wr.writerows(out)
        os.replace(tmp, a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
