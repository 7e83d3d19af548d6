#!/usr/bin/python3
"""Seed 001's packing figures from the validation ledger, beside the paper's Figs. 2 and 4.

    /usr/bin/python3 tools/plot_packing.py [--ledger benchmarks/validation/ledger.json]
                                           [--out benchmarks/validation/packing_seed001]

Reads the full-tier records of the case seed001/packing (tools/validate.py; one record per N, three
packing seeds each, per-seed histograms in `extra`) and writes OUT.csv (one row per N and quantity,
mean and std over the seeds) and OUT.png:
  (a) neighbour-count histogram (share of elements) against Fig. 2 (5000 elements: mean 6.7, about
      1200 elements = 24 % with exactly 6, range 2 to 11);
  (b) shares of e >= 0.4, > 0.7, > 1.2 against Fig. 4 (33 %, < 10 %, < 1 % at N = 5000), overall,
      and the interior share (elements more than one diameter from a surface; goal <= 5 %);
  (c) solid fraction in layers of half a mean diameter from the curved wall (ends excluded),
      mean over the seeds, with the interior value +-0.02 (the goal beyond 4 diameters).
"""
import argparse
import os

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def records(ledger, case):
    import json
    with open(ledger) as f:
        led = json.load(f)
    return sorted((r for r in led["records"] if r["case"] == case and r["tier"] == "full"), key=lambda r: r["N"])


def padded_mean(lists):
    n = max(len(x) for x in lists)
    a = np.array([list(x) + [0.0] * (n - len(x)) for x in lists], float)
    return a.mean(axis=0), a.std(axis=0, ddof=1) if len(a) > 1 else np.zeros(n)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ledger", default=os.path.join(REPO, "benchmarks", "validation", "ledger.json"))
    ap.add_argument("--out", default=os.path.join(REPO, "benchmarks", "validation", "packing_seed001"))
    a = ap.parse_args()
    ecc = records(a.ledger, "seed001/packing_eccentric")
    nb = {r["N"]: r for r in records(a.ledger, "seed001/packing_neighbours")}
    if not ecc:
        raise SystemExit("no full-tier record of seed001/packing in the ledger (python3 -m tools.validate run --tier full "
                         "--case seed001/packing)")
    rows = []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
    for r in ecc:
        n, x = r["N"], r["extra"]
        hist = [np.array(h, float) / sum(h) for h in x["neighbour_histogram"]]
        hm, hs = padded_mean(hist)
        ax[0].errorbar(np.arange(len(hm)), 100 * hm, yerr=100 * hs, marker="o", ms=3, capsize=2, label=f"N = {n}")
        eh = [np.array(h, float) for h in x["eccentricity_histogram"]]
        share = {"e>=0.4": [h[4:].sum() for h in eh], "e>0.7": [h[7:].sum() for h in eh], "e>1.2": [h[12:].sum() for h in eh],
                 "interior e>=0.4": x["eccentric_share_interior"]}
        prof, prof_s = padded_mean(x["density_profile"])
        interior = float(np.mean(x["density_profile_interior"]))
        beyond = prof[8:]  # layers of half a diameter: from 4 diameters on
        if n in nb:
            m = [p["measured"] for p in nb[n]["per_seed"]]
            rows.append((n, "neighbours_mean", float(np.mean(m)), float(np.std(m, ddof=1))))
        rows.append((n, "share_with_6_neighbours", hm[6], hs[6]))
        for k, v in share.items():
            rows.append((n, "share_" + k.replace(" ", "_").replace(">=", "_ge_").replace(">", "_gt_"), float(np.mean(v)),
                         float(np.std(v, ddof=1))))
        rows.append((n, "profile_interior", interior, float(np.std(x["density_profile_interior"], ddof=1))))
        rows.append((n, "profile_max_dev_beyond_4d_of_mean", float(np.max(np.abs(beyond - interior))) if len(beyond) else
                     float("nan"), 0.0))
        k = ecc.index(r)
        for j, (key, v) in enumerate(share.items()):
            ax[1].bar(j + 0.25 * (k - 1), 100 * np.mean(v), 0.25, yerr=100 * np.std(v, ddof=1), capsize=2,
                      color=f"C{k}", label=f"N = {n}" if j == 0 else None)
        ax[2].errorbar((np.arange(len(prof)) + 0.5) * 0.5, prof, yerr=prof_s, marker="o", ms=3, capsize=2,
                       color=f"C{k}", label=f"N = {n} (interior {interior:.3f})")
        ax[2].axhspan(interior - 0.02, interior + 0.02, color=f"C{k}", alpha=0.08)
    ax[0].axvline(6.7, color="k", ls="--", lw=1, label="Fig. 2: mean 6.7")
    ax[0].plot([6], [24], "k*", ms=12, label="Fig. 2: ~1200 of 5000 with 6")
    ax[0].set(xlabel="neighbours (gap <= 0.02 r_mean)", ylabel="share of elements [%]", title="(a) neighbours vs Fig. 2")
    ax[0].legend(fontsize=8)
    ax[1].set_xticks(range(4), ["e >= 0.4", "e > 0.7", "e > 1.2", "interior e >= 0.4"])
    for j, (v, lab) in enumerate(((33, "Fig. 4: 33 %"), (10, "< 10 %"), (1, "< 1 %"), (5, "goal <= 5 %"))):
        ax[1].plot([j - 0.4, j + 0.4], [v, v], "k--", lw=1)
        ax[1].text(j, v + 1, lab, ha="center", fontsize=8)
    ax[1].set(ylabel="share of elements [%]", title="(b) eccentricity (Eq. 2) vs Fig. 4")
    ax[1].legend(fontsize=8)
    ax[2].axvline(4, color="k", ls=":", lw=1)
    ax[2].set(xlabel="distance of the layer from the curved wall [mean diameters]", ylabel="solid fraction",
              title="(c) wall profile, 3 seeds (band: interior +-0.02)")
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    tmp = a.out + ".png.tmp"
    fig.savefig(tmp, dpi=110, format="png")
    os.replace(tmp, a.out + ".png")
    with open(a.out + ".csv.tmp", "w") as f:
        f.write("N,quantity,mean,std\n")
        for n, q, m, s in rows:
            f.write(f"{n},{q},{m:.6g},{s:.6g}\n")
    os.replace(a.out + ".csv.tmp", a.out + ".csv")
    print(f"wrote {a.out}.png and {a.out}.csv")


if __name__ == "__main__":
    main()
