"""Beds the project never tuned on (issue 63 item 5): packed beds whose parameters are drawn once at
random by a seeded generator, for the perf case `mechanics` (benchmarks/perf/cases.py, MECH_SCENES).

A draw (`draw(seed)`, Python's `random.Random(seed)`, four numbers in this order) picks
  law               one of hertz_mindlin, lammps_hertz_tsuji, hooke (sparkdem: linear_spring_dashpot)
  spread            the radii's relative half-width, uniform in [0, 0.4] (radii uniform in r (1 +- spread))
  friction          the Coulomb coefficient, uniform in [0.1, 0.8]
  skin_over_radius  the Verlet skin over the nominal mean radius, uniform in [0.1, 0.5]
each number rounded to 3 decimals (the ends of the ranges are round, so the rounded draw stays inside).
Everything else is fixed and the same for every draw (FIXED, LAWS): 20,000 spheres of 2500 kg/m3
packed frictionless by `fill` to a solid fraction of 0.62 in a 50 mm box closed by six walls (stage
`pack`, not timed; the scene's seed is the draw's), then 10,000 steps of 1e-5 s under gravity with
the drawn law, friction and skin (stage `bed`, timed in both codes from the packed state; see
packed_bed.py). The nominal mean radius is the fill's Eq. 1 for uniform radii,
r = (phi V / (4/3 pi N (1 + spread^2)))^(1/3), so the skin in metres is fixed before the packing.

The scene and its LAMMPS input are committed (random_bed_SEED.json, lammps_random_bed_SEED.in, made
by `python3 -m benchmarks.mechanics.random_beds write SEED ...`) so that a reader sees them; the
perf case checks before it runs that the case table's drawn parameters are the draw of its seed and
that both files are what this module makes of them (`check`).

Like for like (the same law, parameters, skin, walls, steps and step in both codes):
- hertz_mindlin in LAMMPS's terms as in lammps_poly_box_bed.in: `damping tsuji` with the e whose
  Tsuji polynomial gives sparkdem's exact alpha(0.5) = 0.48177, `tangential mindlin NULL` with
  x_gammat = sqrt(6 G* / E*), walls with E / (1 + nu) (this LAMMPS's fix wall/gran takes
  E / (2 (1 - nu)) for a wall; its wall Mindlin stiffness follows LAMMPS's own mixing);
- lammps_hertz_tsuji: the law of lammps_poly_cylinder_bed.in (k_t = 1000 N/m, x_gammat = 1, e = 0.3;
  sparkdem's walls use this LAMMPS's wall modulus by default);
- hooke: `hooke k_n e' tangential linear_history k_t x_gammat mu damping tsuji`: LAMMPS's Tsuji damping
  of a Hooke spring is alpha(e') sqrt(m* k_n), so e' is chosen such that alpha(e') =
  2 (-ln e) / sqrt(pi^2 + ln^2 e), sparkdem's damping for the exact restitution e = 0.5; k_t =
  kt_ratio k_n and x_gammat = gammat_ratio (sparkdem's gamma_t = gammat_ratio gamma_n). sparkdem
  rotates the history into the tangent plane on every row, LAMMPS only above its EPSILON rule
  (negligible; benchmarks/README.md's audit).
"""
import argparse
import json
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
LAWS = ("hertz_mindlin", "lammps_hertz_tsuji", "hooke")
RANGES = {"spread": (0.0, 0.4), "friction": (0.1, 0.8), "skin_over_radius": (0.1, 0.5)}
FIXED = {"particles": 20000, "box_m": 0.05, "target_density": 0.62, "density": 2500.0, "dt": 1e-5, "steps": 10000,
         "youngs_modulus": 1e7, "poisson_ratio": 0.3}
# The fixed parameters of each law besides friction (SI units).
LAW_PARAMS = {"hertz_mindlin": {"restitution": 0.5},
              "lammps_hertz_tsuji": {"restitution": 0.3, "tangential_stiffness": 1000.0, "x_gammat": 1.0},
              "hooke": {"normal_stiffness": 1000.0, "restitution": 0.5, "kt_ratio": 2.0 / 7.0, "gammat_ratio": 0.5}}
# LAMMPS's e for sparkdem's hertz_mindlin at e = 0.5: Tsuji's polynomial of it is 0.48177, the alpha
# sparkdem's exact inversion (kernel::hertz_tsuji_alpha_for_restitution) gives (lammps_poly_box_bed.in).
TSUJI_E_HERTZ_MINDLIN_05 = 0.3666503605


def draw(seed):
    """The drawn parameters of a seed: {seed, law, spread, friction, skin_over_radius}."""
    rng = random.Random(seed)
    u = [rng.random() for _ in range(4)]
    lo_hi = [RANGES[k] for k in ("spread", "friction", "skin_over_radius")]
    vals = [round(a + (b - a) * x, 3) for (a, b), x in zip(lo_hi, u[1:])]
    return {"seed": seed, "law": LAWS[min(int(3 * u[0]), 2)], "spread": vals[0], "friction": vals[1],
            "skin_over_radius": vals[2]}


def name_of(seed):
    return f"random_bed_{seed}"


def nominal_radius(spread):
    """The fill's mean radius (Eq. 1 for radii uniform in r (1 +- spread)) [m]."""
    volume = FIXED["box_m"] ** 3
    return (FIXED["target_density"] * volume / (4.0 / 3.0 * math.pi * FIXED["particles"] * (1.0 + spread ** 2))) ** (1 / 3)


def skin_m(d):
    """The Verlet skin [m], rounded to 1e-9 m (the same number in both codes)."""
    return round(d["skin_over_radius"] * nominal_radius(d["spread"]), 9)


def tsuji_alpha(e):
    """LAMMPS's (and physics/contact/contact_kernels.hpp's) Tsuji polynomial."""
    return (1.2728 - 4.2783 * e + 11.087 * e ** 2 - 22.348 * e ** 3 + 27.467 * e ** 4 - 18.022 * e ** 5
            + 4.8218 * e ** 6)


def tsuji_e_for_alpha(alpha):
    """e in (0, 1) with tsuji_alpha(e) = alpha, by bisection (the polynomial falls on [0, 1])."""
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if tsuji_alpha(mid) > alpha:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def hooke_damping_factor(e):
    """sparkdem's linear_spring_dashpot: gamma_n / sqrt(m* k_n) = 2 (-ln e) / sqrt(pi^2 + ln^2 e)."""
    return 2.0 * -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)


def sparkdem_law(d):
    """The bed stage's contact law block of a draw."""
    p, mu = LAW_PARAMS[d["law"]], d["friction"]
    E, nu = FIXED["youngs_modulus"], FIXED["poisson_ratio"]
    if d["law"] == "hertz_mindlin":
        return {"law": "hertz_mindlin", "params": {"youngs_modulus": E, "poisson_ratio": nu,
                                                   "restitution": p["restitution"], "friction": mu}}
    if d["law"] == "lammps_hertz_tsuji":
        return {"law": "lammps_hertz_tsuji", "params": {"youngs_modulus": E, "restitution": p["restitution"],
                                                        "poisson_ratio": nu, "tangential_stiffness": p["tangential_stiffness"],
                                                        "x_gammat": p["x_gammat"], "friction": mu}}
    return {"law": "linear_spring_dashpot", "params": {"normal_stiffness": p["normal_stiffness"],
                                                       "restitution": p["restitution"], "kt_ratio": p["kt_ratio"],
                                                       "gammat_ratio": p["gammat_ratio"], "friction": mu}}


def scene(d):
    """The packed-bed scene of a draw (stages `pack` and `bed`, as packed_bed.py expects)."""
    n, box = FIXED["particles"], FIXED["box_m"]
    return {
        "name": name_of(d["seed"]),
        "description": (f"A bed the project never tuned on (issue 63 item 5; benchmarks/mechanics/random_beds.py): "
                        f"parameters drawn once by random.Random({d['seed']}): law {d['law']}, radii uniform in "
                        f"r (1 +- {d['spread']}), friction {d['friction']}, Verlet skin {d['skin_over_radius']} of the "
                        f"nominal mean radius ({skin_m(d)} m). {n} spheres packed frictionless by `fill` to a solid "
                        f"fraction of {FIXED['target_density']} between six walls (stage `pack`, not timed), then "
                        f"{FIXED['steps']} steps of {FIXED['dt']} s under gravity with the drawn law (stage `bed`, "
                        f"timed; LAMMPS: lammps_{name_of(d['seed'])}.in)."),
        "seed": d["seed"],
        "materials": [{"name": "glass", "density": FIXED["density"]}],
        "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": FIXED["youngs_modulus"],
                                                       "poisson_ratio": FIXED["poisson_ratio"], "restitution": 0.5,
                                                       "friction": 0.0}},
        "stages": [
            {"name": "pack", "type": "fill",
             "generator": {"shape": "box", "lo": [0, 0, 0], "hi": [box, box, box], "particles": n,
                           "spread": d["spread"], "target_density": FIXED["target_density"], "initial_scale": 0.5,
                           "growth_time": 0.02, "damping_rate": 50, "ke_per_mass_below": 1e-6, "max_overlap": 0.02},
             "dt": FIXED["dt"], "stop": {"steps": 60000, "check_every": 100}, "output": {"timeseries_every": 1000}},
            {"name": "bed", "type": "dynamics", "dt": FIXED["dt"], "skin": skin_m(d), "contact": sparkdem_law(d),
             "modules": {"gravity": {"acceleration": [0, 0, -9.81]}}, "stop": {"steps": FIXED["steps"]},
             "output": {"frame_every": 0, "timeseries_every": 500, "checkpoint_every": 0}}]}


def lammps_models(d):
    """(pair model, wall model): LAMMPS `granular` model strings of a draw's law."""
    p, mu = LAW_PARAMS[d["law"]], d["friction"]
    E, nu = FIXED["youngs_modulus"], FIXED["poisson_ratio"]
    if d["law"] == "hertz_mindlin":
        g_star = E / (2 * (1 + nu)) / (2 * (2 - nu))
        e_star = E / (2 * (1 - nu * nu))
        tail = f"{TSUJI_E_HERTZ_MINDLIN_05:.10g} {nu:g} tangential mindlin NULL {math.sqrt(6 * g_star / e_star):.12g} {mu:g} damping tsuji"
        return f"hertz/material {E!r} {tail}", f"hertz/material {E / (1 + nu)!r} {tail}"
    if d["law"] == "lammps_hertz_tsuji":
        m = (f"hertz/material {E!r} {p['restitution']:g} {nu:g} tangential linear_history "
             f"{p['tangential_stiffness']!r} {p['x_gammat']!r} {mu:g} damping tsuji")
        return m, m
    kn = p["normal_stiffness"]
    e_l = tsuji_e_for_alpha(hooke_damping_factor(p["restitution"]))
    m = (f"hooke {kn!r} {e_l:.12g} tangential linear_history {p['kt_ratio'] * kn!r} {p['gammat_ratio']!r} {mu:g} "
         f"damping tsuji")
    return m, m


def lammps_input(d):
    """The LAMMPS input of a draw's bed stage (run in a directory holding bed.data and bed_walls.in)."""
    pair, wall = lammps_models(d)
    name = name_of(d["seed"])
    notes = {"hertz_mindlin": "# hertz_mindlin in LAMMPS's terms as in lammps_poly_box_bed.in (Tsuji e giving alpha = 0.48177,\n"
                              "# mindlin x_gammat = sqrt(6 G*/E*), walls with E / (1 + nu)).",
             "lammps_hertz_tsuji": "# lammps_hertz_tsuji: LAMMPS's own law (sparkdem's walls use this LAMMPS's wall modulus).",
             "hooke": "# hooke (sparkdem's linear_spring_dashpot): Tsuji damping of a Hooke spring is alpha(e') sqrt(m* k_n);\n"
                      "# e' gives sparkdem's exact-restitution damping for e = 0.5; k_t = kt_ratio k_n, x_gammat = gammat_ratio."}
    lines = [f"# {name}: made by benchmarks/mechanics/random_beds.py from the draw of seed {d['seed']} (issue 63 item 5):",
             f"# law {d['law']}, spread {d['spread']}, friction {d['friction']}, skin {d['skin_over_radius']} of the nominal",
             f"# mean radius = {skin_m(d)} m. The stage `bed` of {name}.json; the perf harness (benchmarks/perf/cases.py)",
             "# writes bed.data (the packed particles) and bed_walls.in (the six walls) into the run directory.",
             notes[d["law"]],
             f"# Run: lmp -in lammps_{name}.in -log none (in a directory holding bed.data and bed_walls.in)",
             "units           si", "atom_style      sphere", "boundary        f f f", "newton          off",
             "comm_modify     vel yes", "include         bed_walls.in", "read_data       bed.data",
             "pair_style      granular", f"pair_coeff      * * {pair}",
             "fix             grav all gravity 9.81 vector 0 0 -1", "fix             int all nve/sphere"]
    lines += [f"fix             {a}w all wall/gran granular {wall} {a}plane ${{{a}lo}} ${{{a}hi}}" for a in "xyz"]
    lines += [f"neighbor        {skin_m(d)!r} bin", "neigh_modify    delay 0 every 1 check yes",
              f"timestep        {FIXED['dt']:g}", "compute         erot all erotate/sphere", "thermo          500",
              "thermo_style    custom step atoms ke c_erot", "thermo_modify   format float %.10g",
              f"run             {FIXED['steps']}",
              "write_dump      all custom lammps_final.dump id x y z radius modify format float %.12g"]
    return "\n".join(lines) + "\n"


def paths(seed):
    """(scene, LAMMPS input) paths, repository-relative."""
    return (f"benchmarks/mechanics/{name_of(seed)}.json", f"benchmarks/mechanics/lammps_{name_of(seed)}.in")


def write(seed, repo):
    for rel, text in zip(paths(seed), (json.dumps(scene(draw(seed)), indent=1) + "\n", lammps_input(draw(seed)))):
        path = os.path.join(repo, rel)
        with open(path + ".tmp", "w") as f:
            f.write(text)
        os.replace(path + ".tmp", path)
        print(f"wrote {rel}")


def check(spec, repo):
    """A MECH_SCENES entry with a `draw`: the table's drawn parameters are the draw of its seed, and
    its scene and LAMMPS input are the committed files this module makes of them. Raises RuntimeError."""
    d = spec["draw"]
    if draw(d["seed"]) != d:
        raise RuntimeError(f"the case table's draw {d} is not the draw of seed {d['seed']}: {draw(d['seed'])}")
    want_scene, want_in = paths(d["seed"])
    if (spec["config"], spec["lammps"]) != (want_scene, want_in):
        raise RuntimeError(f"seed {d['seed']}: the case table names {spec['config']}, {spec['lammps']}; "
                           f"expected {want_scene}, {want_in}")
    with open(os.path.join(repo, want_scene)) as f:
        same_scene = json.load(f) == json.loads(json.dumps(scene(d)))
    with open(os.path.join(repo, want_in)) as f:
        same_in = f.read() == lammps_input(d)
    if not (same_scene and same_in):
        raise RuntimeError(f"{want_scene if not same_scene else want_in} is not what random_beds.py makes of seed "
                           f"{d['seed']} (python3 -m benchmarks.mechanics.random_beds write {d['seed']})")
    return f"drawn from seed {d['seed']} (checked): {d['law']}, spread {d['spread']}, friction {d['friction']}, " \
           f"skin {d['skin_over_radius']} r = {skin_m(d)} m"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("draw", help="print the draw of each seed")
    p.add_argument("seeds", type=int, nargs="+")
    p = sub.add_parser("write", help="write each seed's scene and LAMMPS input under benchmarks/mechanics/")
    p.add_argument("seeds", type=int, nargs="+")
    a = ap.parse_args(argv)
    repo = os.path.dirname(os.path.dirname(HERE))
    for s in a.seeds:
        if a.cmd == "draw":
            print(json.dumps(draw(s)))
        else:
            write(s, repo)
    return 0


if __name__ == "__main__":
    sys.exit(main())
