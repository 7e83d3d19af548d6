#!/usr/bin/python3
"""Issue 38 item 1's consequence for the beams: does E_M in tension stay flat over N when the
sample is packed to a fixed interior? The ledger's seed001/beam_elastic scene
(configs/calibration/cast_iron_tension.json with the committed beams, strength 1e30: nothing
breaks; benchmarks/validation/cases.py run_beam_elastic) packed by relax's interior_target_density
(default 0.6574, fixed by benchmarks/resistance_cylinder/interior_packing.py from packings alone),
at each N and packing seed, one thread per run, two runs at a time. The overall protocol's figures
are the ledger's (seed001/beam_E_M, seed001/beam_nu_M).

Columns: N, seed, E_M [Pa], E_M / 124 GPa - 1, nu_M, nu_M / 0.29 - 1, bonds per element, the packing's
overall and interior (4 mean diameters in) solid fractions, interior rounds, wall time.

    python3 -m benchmarks.beam_calibration.interior_transfer --sparkdem BIN --workdir DIR
        [--n 2500,4000,5000,10000] [--seeds 1,2,3] [--interior 0.6574]
        [--beams configs/materials/cast_iron_beams.json]
        [--csv benchmarks/beam_calibration/interior_transfer.csv]

With --beams configs/materials/cast_iron_beams_torsion.json (the beams calibrated in torsion on the
pin, issue 38 item 3) it is that calibration's transfer test to another stress state:
interior_transfer_torsion_beams.csv.
"""
import concurrent.futures
import json
import os

from benchmarks.perf.harness import print_means, run_study_scene, study_parser, write_csv_atomic
from tools import sps_outputs as so

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run(sparkdem, workdir, n, seed, interior, beams_file):
    path = os.path.join(REPO, "configs/calibration/cast_iron_tension.json")
    with open(path) as f:
        c = json.load(f)
    so.absolute_includes(c, os.path.dirname(path))
    with open(os.path.join(REPO, beams_file)) as f:
        beams = json.load(f)
    c["seed"] = seed
    c["bonds"]["params"] = dict(beams, strength=1e30)
    gen = c["stages"][0]["generator"]
    gen["particles"] = n
    gen["interior_target_density"] = interior
    _, s = run_study_scene(sparkdem, workdir, f"N{n}_s{seed}", c)
    st = {x["name"]: x for x in s["stages"]}
    h, pk = st["hold"]["final"], st["cook"]["packing"]
    return {"N": n, "seed": seed, "E_M": h["tension_young_modulus"], "E_err": h["tension_young_modulus"] / 124e9 - 1.0,
            "nu_M": h["tension_poisson_ratio"], "nu_err": h["tension_poisson_ratio"] / 0.29 - 1.0,
            "bonds_per_element": 2.0 * h["bonds"] / n, "packing_density": pk["packing_density"],
            "density_profile_interior": pk["density_profile_interior"], "interior_rounds": pk.get("interior_rounds"),
            "wall_time_s": s["wall_time_s"]}


def main():
    ap = study_parser(__doc__, "2500,4000,5000,10000", "benchmarks/beam_calibration/interior_transfer.csv")
    ap.add_argument("--interior", type=float, default=0.6574)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--beams", default="configs/materials/cast_iron_beams.json",
                    help="the beams (relative to the repository): the tension calibration's, or "
                         "configs/materials/cast_iron_beams_torsion.json (issue 38 item 3's transfer test)")
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    jobs = [(int(n), int(s)) for n in a.n.split(",") for s in a.seeds.split(",")]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(lambda j: run(os.path.abspath(a.sparkdem), a.workdir, j[0], j[1], a.interior, a.beams), jobs))
    write_csv_atomic(a.csv, rows)
    print_means(rows, ("N",), ("E_err", "nu_err", "bonds_per_element", "packing_density", "density_profile_interior"))


if __name__ == "__main__":
    main()
