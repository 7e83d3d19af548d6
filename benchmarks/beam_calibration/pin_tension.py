#!/usr/bin/python3
"""Issue 58's two misses, measured on one packing: the torsion pin pulled in tension.

configs/torsion_contact.json's pack stage and beams unchanged (same seed and N: the same packing
and the same beams as that seed's torsion run), its twist stage replaced by the tension scene's
pull and hold (configs/calibration/cast_iron_tension.json: one end clamped, the other pulled at
0.01 m/s for 40 us, then held 20 us under local damping; strength 1e30, nothing breaks). So the
tension modulus and the torsion stiffness of the ledger's seed001/torsion_contact run of the same
seed come from one packing: their ratio is the stress-state part of the tension transfer
(seed001/beam_contact_E_M, packed by the tension scene's own protocol); the rest is the packing.

Columns: N, seed, E_M [Pa], E_M / 124 GPa - 1, nu_M, nu_M / 0.29 - 1, beams per element, the
torsion stiffness ratio of the same seed's ledger run (blank when the ledger has none), wall time.

    python3 -m benchmarks.beam_calibration.pin_tension --sparkdem BIN --workdir DIR
        [--n 5000,10000] [--seeds 1,2,3,4,5] [--csv benchmarks/beam_calibration/pin_tension.csv]
"""
import concurrent.futures
import json
import os

from benchmarks.perf.harness import load_config, print_means, run_study_scene, study_parser, write_csv_atomic

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LEDGER_RUNS = os.path.join(REPO, "benchmarks/validation/runs/full/seed001_torsion_contact")


def pin_in_tension(n, seed):
    """The torsion pin's scene with its twist replaced by the tension scene's pull and hold."""
    pin = load_config("configs/torsion_contact.json")
    tension = load_config("configs/calibration/cast_iron_tension.json")
    pin["seed"] = seed
    pin["stages"][0]["generator"]["particles"] = n
    pin["bonds"]["params"]["strength"] = 1e30
    twist = pin["stages"][1]
    stages = [st for st in tension["stages"] if st["name"] in ("pull", "hold")]
    for st in stages:
        st["prescribe"] = {"clamped": [0, 0, 0], "twisted": st["prescribe"]["top"]}
        st["sets"] = ["clamped", "twisted"]
        st["modules"]["tension_test"].update(pulled="twisted", fixed="clamped")
    stages[0]["create_bonds"] = twist["create_bonds"]
    stages[0]["remove_walls"] = twist["remove_walls"]
    pin["stages"] = [pin["stages"][0]] + stages
    pin.pop("checks", None)
    return pin


def torsion_stiffness(n, seed):
    path = os.path.join(LEDGER_RUNS, f"N{n}.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        runs = json.load(f)["runs"]
    return next((r["figures"]["stiffness"]["measured"] for r in runs if r["seed"] == seed), None)


def run(sparkdem, workdir, n, seed):
    _, s = run_study_scene(sparkdem, workdir, f"N{n}_s{seed}", pin_in_tension(n, seed))
    h = {x["name"]: x for x in s["stages"]}["hold"]["final"]
    return {"N": n, "seed": seed, "E_M": h["tension_young_modulus"], "E_err": h["tension_young_modulus"] / 124e9 - 1.0,
            "nu_M": h["tension_poisson_ratio"], "nu_err": h["tension_poisson_ratio"] / 0.29 - 1.0,
            "bonds_per_element": h["bonds"] / n, "torsion_stiffness_ratio": torsion_stiffness(n, seed),
            "wall_time_s": s["wall_time_s"]}


def main():
    ap = study_parser(__doc__, "5000,10000", "benchmarks/beam_calibration/pin_tension.csv", "1,2,3,4,5")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    jobs = [(int(n), int(s)) for n in a.n.split(",") for s in a.seeds.split(",")]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(lambda j: run(os.path.abspath(a.sparkdem), a.workdir, j[0], j[1]), jobs))
    write_csv_atomic(a.csv, rows)
    print_means(rows, ("N",), ("E_err", "nu_err", "bonds_per_element"))


if __name__ == "__main__":
    main()
