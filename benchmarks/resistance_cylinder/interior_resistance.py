#!/usr/bin/python3
"""Issue 38 item 2 on the interior packing protocol: the pin's resistance error and where it lives.
Runs configs/resistance_cylinder.json (relax, then the transmission-surface network between the
end sets) at each N and packing seed, packed by the `overall` protocol (the ledger's: overall
fraction 0.63) or the `interior` one (relax's interior_target_density, default 0.6574: fixed by
interior_packing.py from packings alone), and writes per run:

  R_rel_error     R / R_th - 1, R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2) (the ledger's convention)
  core_kappa_rho  kappa rho_e of the core r < r_d - 4 r_mean (locate_error.ring_kappa: axial current
                  through 21 planes of the middle half over area x |dphi/dz|); 1 = the continuum
  skin_c          R_rel_error / (r_mean / r_d): Table III's errors are 0.60 +- 0.03 x r_mean / r_d
  packing_density, density_profile_interior, neighbours_mean, eccentric_share

    python3 -m benchmarks.resistance_cylinder.interior_resistance --sparkdem BIN --workdir DIR
        [--n 5000,10000,20000] [--seeds 1,2,3] [--protocols overall,interior] [--interior 0.6574]
        [--csv benchmarks/resistance_cylinder/interior_resistance.csv]
"""
import glob
import json
import math
import os

import h5py

from benchmarks.perf.harness import print_means, run_study_scene, study_parser, write_csv_atomic
from benchmarks.resistance_cylinder.locate_error import ring_kappa

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run(sparkdem, workdir, protocol, n, seed, interior):
    with open(os.path.join(REPO, "configs/resistance_cylinder.json")) as f:
        c = json.load(f)
    c["seed"] = seed
    gen = c["stages"][0]["generator"]
    gen["particles"] = n
    if protocol == "interior":
        gen["interior_target_density"] = interior
    out, s = run_study_scene(sparkdem, workdir, f"{protocol}_N{n}_s{seed}", c, threads=2)
    pk = s["stages"][0]["packing"]
    fin = [t for t in s["stages"] if "electrical_resistance" in t.get("final", {})][-1]["final"]
    m = c["stages"][1]["modules"]["electrical_network"]
    rho = m["resistivity"]
    rd, ld = gen["radius"], gen["length"]
    with h5py.File(sorted(glob.glob(os.path.join(out, "frames", "*.h5")))[-1], "r") as f:
        r_mean = float(f["particles/radius"][:].mean())
        kappa, _ = ring_kappa(f, [0.0, rd - 4.0 * r_mean, 10.0 * rd], ld, rd)
    r_th = rho * (ld - 2.0 * r_mean) / (math.pi * rd ** 2)
    err = fin["electrical_resistance"] / r_th - 1.0
    return {"protocol": protocol, "N": n, "seed": seed, "R_rel_error": err, "core_kappa_rho": kappa[0] * rho,
            "skin_c": err / (r_mean / rd), "r_mean_over_rd": r_mean / rd, "packing_density": pk["packing_density"],
            "density_profile_interior": pk["density_profile_interior"], "neighbours_mean": pk["neighbours_mean"],
            "eccentric_share": pk["eccentric_share"]}


def main():
    ap = study_parser(__doc__, "5000,10000,20000", "benchmarks/resistance_cylinder/interior_resistance.csv")
    ap.add_argument("--protocols", default="overall,interior")
    ap.add_argument("--interior", type=float, default=0.6574)
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    sparkdem = os.path.abspath(a.sparkdem)
    rows = [run(sparkdem, a.workdir, proto, int(n), int(s), a.interior)
            for proto in a.protocols.split(",") for n in a.n.split(",") for s in a.seeds.split(",")]
    write_csv_atomic(a.csv, rows)
    print_means(rows, ("protocol", "N"), ("R_rel_error", "core_kappa_rho", "skin_c", "packing_density"))


if __name__ == "__main__":
    main()
