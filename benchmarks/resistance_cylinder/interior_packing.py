#!/usr/bin/python3
"""Issue 38 item 1: does the pin's interior depend on N? Packs configs/resistance_cylinder.json's
cylinder (r_d = 1 mm, l_d = 5 mm, radii uniform in r(1 +- 0.125)) with the relax generator at each
N and packing seed, by one of two protocols, and writes per packing the generator's report:

  overall     target_density 0.63 (the seed's "around 63 %", the ledger's protocol of issues 19/20)
  interior    interior_target_density PHI (the solid fraction more than 4 mean diameters from every
              face), the overall fraction following; PHI given with --interior, or (default) fixed
              before any interior run from the `overall` runs alone: the middle of the window of PHI
              whose overall fraction stays within the seed's "around 63 %" (0.62-0.64) at every N,
              PHI - deficit(N) in [0.62, 0.64], deficit(N) = mean interior - overall at N

Columns: protocol, N, seed, packing_density (overall), density_profile_interior (4 mean diameters
in from every face), neighbours_mean (gap <= 0.02 r_mean, all elements), neighbours_mean_core (the
same, elements centred 4 mean diameters in), coordination_interior (touching), eccentric_share,
interior_rounds, wall_time_s.

    python3 -m benchmarks.resistance_cylinder.interior_packing --sparkdem BIN --workdir DIR
        [--n 2500,5000,10000,20000,40000] [--seeds 1,2,3] [--interior PHI]
        [--csv benchmarks/resistance_cylinder/interior_packing.csv]
"""
import json
import os
import statistics

from benchmarks.perf.harness import print_means, run_study_scene, study_parser, write_csv_atomic

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
KEYS = ("packing_density", "density_profile_interior", "neighbours_mean", "neighbours_mean_core", "coordination_interior",
        "eccentric_share", "interior_rounds", "interior_density_reached")


def pack(sparkdem, workdir, n, seed, interior=None):
    with open(os.path.join(REPO, "configs/resistance_cylinder.json")) as f:
        c = json.load(f)
    c["seed"] = seed
    c["stages"] = c["stages"][:1]  # the packing alone
    gen = c["stages"][0]["generator"]
    gen["particles"] = n
    if interior is not None:
        gen["interior_target_density"] = interior
    _, s = run_study_scene(sparkdem, workdir, f"{'interior' if interior else 'overall'}_N{n}_s{seed}", c, threads=2)
    st = s["stages"][0]
    rep = st["packing"]
    return {"protocol": "interior" if interior else "overall", "N": n, "seed": seed, **{k: rep.get(k) for k in KEYS},
            "wall_time_s": st["wall_time_s"]}


def main():
    ap = study_parser(__doc__, "2500,5000,10000,20000,40000", "benchmarks/resistance_cylinder/interior_packing.csv")
    ap.add_argument("--interior", type=float, default=None)
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    sparkdem = os.path.abspath(a.sparkdem)
    ns, seeds = [int(x) for x in a.n.split(",")], [int(x) for x in a.seeds.split(",")]
    rows = [pack(sparkdem, a.workdir, n, s) for n in ns for s in seeds]
    phi = a.interior
    if phi is None:
        deficit = [statistics.mean(r["density_profile_interior"] - r["packing_density"] for r in rows if r["N"] == n) for n in ns]
        lo, hi = 0.62 + max(deficit), 0.64 + min(deficit)
        phi = round(0.5 * (lo + hi), 4)
        print(f"window of the interior target: [{lo:.4f}, {hi:.4f}]{' (empty)' if lo > hi else ''}; target {phi}")
    rows += [pack(sparkdem, a.workdir, n, s, phi) for n in ns for s in seeds]
    write_csv_atomic(a.csv, rows)
    print(f"interior target {phi}")
    print_means(rows, ("protocol", "N"), ("packing_density", "density_profile_interior", "neighbours_mean", "neighbours_mean_core"))


if __name__ == "__main__":
    main()
