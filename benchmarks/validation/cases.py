"""The table of validation cases run by tools/validate.py (benchmarks/validation/README.md).

A Case names its configs, the sizes and packing seeds of its two tiers, and `run(ctx)`: it writes
the scenario of one run (N and seed patched into a copy of the config), runs it through
ctx.sparkdem (and any reference tool through ctx.command) and returns its figures as
{key: {"measured": x, "reference": y, "extra": {...}}}. Each Figure names the ledger case id, the
source, where the reference comes from, the band (relative), what was calibrated and on which
case, and every parameter chosen after seeing the figure (`tuned`: such a figure is reported, never
a pass). References are fixed before the run: a seed's table, a closed form evaluated from the
config, or a reference tool of the repository run on the packing before the physics stage.

Sizes: "full" is the published N (and packings), "fast" a size whose run takes seconds (CI; its
band comes from fast_bands.json, derived from measured scatter over seeds).
"""
import glob
import json
import math
import os
import sys

from benchmarks.sps_nial.networks import KAPPA_B, hs as hs_factor  # the bulk kappa_0 and the Hashin-Shtrikman factor

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class Figure:
    def __init__(self, id, key, source, reference_origin, band, calibrated_on="", tuned=(), variants=(),
                 min_seeds=3, tiers=None, absolute=False, kind="validation", calibration_sizes=(), sizes=None,
                 shares_values_with=()):
        """band: the relative half-width, or {N: half-width} where VALIDATION.md sets it per size
        (the largest listed N at or below the run's N applies); absolute: the error is measured -
        reference and the band a half-width in the figure's unit (e.g. porosity +-0.02).
        kind: "validation", "construction" for a figure the set-up makes true (reported, never
        judged), or "study" for a scan variant or a reading of numerics the source does not give
        (issue 60: reported beside the validations, never judged, not in the headline table); calibration_sizes: the N whose full-tier record is the calibration run's own
        residual (kind "calibration"); the fast tier is "regression" (tools/ledger.py: record_kind).
        tiers / sizes: the tiers and N the figure is defined at (None: all of the case's);
        shares_values_with: figures this one may equal in every run by design (check-ledger's
        one-run-counted-twice rule lets them)."""
        self.absolute, self.kind, self.calibration_sizes = absolute, kind, list(calibration_sizes)
        self.id, self.key, self.source, self.reference_origin = id, key, source, reference_origin
        self.band, self.calibrated_on, self.tuned, self.variants = band, calibrated_on, list(tuned), list(variants)
        self.min_seeds, self.tiers, self.sizes = min_seeds, tiers, sizes
        self.shares_values_with = list(shares_values_with)

    def applies(self, tier, n):
        return (not self.tiers or tier in self.tiers) and (not self.sizes or n in self.sizes)

    def band_at(self, n):
        if not isinstance(self.band, dict):
            return self.band
        return self.band[max([k for k in self.band if k <= n] or [min(self.band)])]


class Case:
    def __init__(self, id, configs, tiers, run, figures):
        self.id, self.configs, self.tiers, self.run, self.figures = id, configs, tiers, run, figures


# ---------------------------------------------------------------- shared readers

def load_json(path):
    with open(path) as f:
        return json.load(f)


def summary(out):
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def stage(s, name):
    st = [x for x in s["stages"] if x["name"] == name]
    if not st:
        raise KeyError(f"stage {name} not in summary.json")
    return st[-1]


def only_stage(c, **match):
    st = [x for x in c["stages"] if all(x.get(k) == v for k, v in match.items())]
    if len(st) != 1:
        raise ValueError(f"expected one stage with {match}, found {len(st)}")
    return st[0]


def check(s, name):
    c = s.get("checks", {}).get(name)
    if c is None or "value" not in c:
        raise KeyError(f"check {name} has no value: {c}")
    return c


def last_frame_radii(out):
    import h5py
    frame = sorted(glob.glob(os.path.join(out, "frames", "frame_*.h5")))[-1]
    with h5py.File(frame, "r") as f:
        return f["particles/radius"][:]


def fig(measured, reference, **extra):
    return {"measured": float(measured), "reference": float(reference), "extra": extra}


# ---------------------------------------------------------------- seed 001: cylinder resistance

# Table III of seed 001: GranOO's error of R against R_th at N (the reproduce goal, issue 58 item 3).
TABLE3 = {5000: 0.0465, 10000: 0.0377, 20000: 0.0285}


def run_cylinder(ctx, gap_relative=None):
    """gap_relative: None runs the config (branches between elements in contact, gap <= 0); a number
    counts pairs with gap <= gap_relative r_mean as branches and neighbours (the earlier convention)."""
    c = ctx.config("configs/resistance_cylinder.json")
    c["seed"] = ctx.seed
    g = only_stage(c, type="relax")["generator"]
    g["particles"] = ctx.n
    m = next(st["modules"]["electrical_network"] for st in c["stages"] if "electrical_network" in st.get("modules", {}))
    if gap_relative is not None:
        g["neighbour_gap_relative"] = gap_relative
        m.pop("touch_tolerance", None)
        m["touch_tolerance_relative"] = gap_relative
    out = ctx.sparkdem(c)
    s = summary(out)
    el = [x for x in s["stages"] if "electrical_resistance" in x.get("final", {})][-1]
    rho = m["resistivity"] if m.get("resistivity", 0) > 0 else 1.0 / m["conductivity"]
    r_mean = float(last_frame_radii(out).mean())
    r_th = rho * (g["length"] - 2.0 * r_mean) / (math.pi * g["radius"] ** 2)
    pk = stage(s, only_stage(c, type="relax")["name"]).get("packing", {})
    from benchmarks.resistance_cylinder.locate_error import deep_bulk
    bulk = deep_bulk(out) if ctx.tier == "full" else {}  # the fast sizes have no bulk 6 r_mean from the wall
    R = el["final"]["electrical_resistance"]
    figs = {"R": fig(R, r_th, r_mean_m=r_mean, packing_density=pk.get("packing_density"),
                     coordination=pk.get("coordination_mean"), electrode_share=bulk.get("electrode_share", math.nan))}
    if gap_relative is None and ctx.tier == "full":
        figs["deep"] = fig(bulk["deep_kappa_rho"], 1.0, deep_radius_m=bulk["deep_radius_m"])
        if ctx.n in TABLE3:
            figs["R_table3"] = fig(R, r_th * (1.0 + TABLE3[ctx.n]), table3_error=TABLE3[ctx.n])
    return figs


CYLINDER_SRC = "seed 001 (Hubert et al. 2017) §3.1, Table III (GranOO 2.9 % at N = 20,000)"
CYLINDER_REF = ("R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2), r_d = 1 mm, l_d = 5 mm, 304L, r_mean the packing's mean "
                "radius (Eq. 17; convention fixed in VALIDATION.md)")
# Issue 58: the branches between elements in contact (gap <= 0) were chosen after re-solves of R at
# gap <= 0 had been seen (benchmarks/resistance_cylinder/sensitivity_interior.csv): every figure of
# the cylinder at gap <= 0 carries this mark; it is shown, never a pass.
CONTACT_SEEN = [{"parameter": "configs/resistance_cylinder.json#touch_tolerance (branches at gap <= 0)",
                 "why": "the paper's contact definition (issue 58) was adopted after re-solves of this cylinder's R at "
                        "gap <= 0 had been seen (benchmarks/resistance_cylinder/sensitivity_interior.csv: +3.1 / +3.2 % "
                        "predicted at N = 20,000): seen, never a pass"}]
CYLINDER = Case(
    "seed001/cylinder", ["configs/resistance_cylinder.json"],
    {"fast": {"sizes": [300], "seeds": [1]}, "full": {"sizes": [5000, 10000, 20000, 40000], "seeds": [1, 2, 3]}},
    run_cylinder,
    [Figure("seed001/cylinder_resistance", "R", CYLINDER_SRC,
            CYLINDER_REF + "; branches between elements in contact (gap <= 0); band: VALIDATION.md's 'beyond' 1.5 %",
            0.015, tuned=CONTACT_SEEN),
     Figure("seed001/cylinder_resistance_table3", "R_table3", CYLINDER_SRC + ": reproduce",
            "R_th (1 + e_III(N)), e_III Table III's error at N (4.65 / 3.77 / 2.85 % at 5k / 10k / 20k): the error "
            "against GranOO's own; band 1.5 points (issue 58 item 3: 2.9 +- 1.5 % at N = 20,000)", 0.015,
            tuned=CONTACT_SEEN, tiers=["full"], sizes=sorted(TABLE3)),
     Figure("seed001/cylinder_deep_bulk", "deep", CYLINDER_SRC + ": gate G3 of issue 58",
            "kappa rho_e = 1 (the continuum) in the disc r < r_d - 6 r_mean: the axial current of the branches crossing "
            "21 planes of the middle half over the disc area and the fitted potential gradient "
            "(benchmarks/resistance_cylinder/locate_error.py deep_bulk); gate at N >= 20,000", 0.01,
            tuned=CONTACT_SEEN, tiers=["full"])])


def run_cylinder_gap002(ctx):
    return run_cylinder(ctx, gap_relative=0.02)


CYLINDER_GAP002 = Case(
    "seed001/cylinder_gap002", ["configs/resistance_cylinder.json"],
    {"full": {"sizes": [5000, 10000, 20000, 40000], "seeds": [1, 2, 3]}},
    run_cylinder_gap002,
    [Figure("seed001/cylinder_resistance_gap002", "R", CYLINDER_SRC + " (the earlier neighbour definition)",
            CYLINDER_REF + "; branches and neighbours at gap <= 0.02 r_mean (issue 38's convention, fixed from Fig. 2's "
            "mean 6.7; cases.run_cylinder_gap002 patches the config)", 0.015)])


def run_cylinder_fit(ctx):
    """Gate G4 of issue 58: error = a + c r_mean / r_d fitted (least squares, free intercept) over every
    run of the cylinder's full-tier records (N 5k-40k, 3 seeds), from their run files; the config
    must be the one they were run with."""
    import numpy as np
    here = os.path.join(REPO, "benchmarks", "validation", "runs", "full", "seed001_cylinder")
    x, y, share, used = [], [], [], []
    from tools.validate import config_hashes
    now = config_hashes(CYLINDER)
    for path in sorted(glob.glob(os.path.join(here, "N*.json"))):
        rf = load_json(path)
        if rf.get("configs") != now:
            raise RuntimeError(f"{path} was run on other configs: rerun seed001/cylinder (full) first")
        for r in rf["runs"]:
            f = r["figures"]["R"]
            x.append(f["extra"]["r_mean_m"] / 1e-3)
            y.append(f["measured"] / f["reference"] - 1.0)
            share.append(f["extra"]["electrode_share"])
            used.append(f"N{rf['N']}_seed{r['seed']}")
    A = np.vstack([np.ones(len(x)), x]).T
    coef, res, _, _ = np.linalg.lstsq(A, np.array(y), rcond=None)
    dof = len(x) - 2
    s2 = float(np.sum((A @ coef - np.array(y)) ** 2)) / dof
    cov = s2 * np.linalg.inv(A.T @ A)
    a, c = float(coef[0]), float(coef[1])
    side = dict(runs=used, intercept_std=float(np.sqrt(cov[0, 0])), slope_std=float(np.sqrt(cov[1, 1])),
                electrode_share_mean=float(np.mean(share)), electrode_share_std=float(np.std(share, ddof=1)),
                residual_std=float(np.sqrt(s2)))
    return {"a": fig(a, 0.0, **side), "c": fig(c, 0.62, **side)}


CYLINDER_FIT = Case(
    "seed001/cylinder_error_structure", ["configs/resistance_cylinder.json"],
    {"full": {"sizes": [0], "seeds": [1]}},
    run_cylinder_fit,
    [Figure("seed001/cylinder_fit_intercept", "a", CYLINDER_SRC + ": gate G4 of issue 58",
            "error = a + c r_mean / r_d over the full-tier cylinder runs (N 5k-40k x 3 seeds, least squares with a free "
            "intercept; Table III over N >= 5000: a = -0.13 +- 1.13 %): |a| <= 1.1 % (absolute band 0.011)", 0.011,
            absolute=True, min_seeds=1, tuned=CONTACT_SEEN),
     Figure("seed001/cylinder_fit_slope", "c", CYLINDER_SRC + ": gate G4 of issue 58",
            "the skin slope c of the same fit against Table III's 0.62 (free intercept; 0.597 +- 0.031 with a zero "
            "one): c = 0.62 +- 0.25 (absolute band)", 0.25, absolute=True, min_seeds=1, tuned=CONTACT_SEEN)])


# ---------------------------------------------------------------- seed 001: packing protocol

def run_packing(ctx):
    """The seed-001 packing protocol alone (the cook stage of configs/resistance_cylinder.json)."""
    c = ctx.config("configs/resistance_cylinder.json")
    c["seed"] = ctx.seed
    cook = only_stage(c, type="relax")
    cook["generator"]["particles"] = ctx.n
    c["stages"] = [cook]
    c.pop("particle_sets", None)
    pk = stage(summary(ctx.sparkdem(c)), cook["name"])["packing"]
    # Gate G2 (issue 58): the same packing with the relaxation's force tolerance halved.
    half = json.loads(json.dumps(c))
    half["stages"][0]["generator"]["force_tolerance"] *= 0.5
    pk_half = stage(summary(ctx.sparkdem(half, "half_tolerance")), cook["name"])["packing"]
    hist = {k: pk.get(k) for k in ("neighbour_histogram", "coordination_histogram", "eccentricity_histogram",
                                   "density_profile")}
    side = dict(eccentric_share_interior=pk["eccentric_share_interior"], interior_share=pk["interior_share"],
                contacts_mean=pk["coordination_mean"], density_profile_interior=pk["density_profile_interior"],
                density_profile_max_deviation_beyond_4d=pk["density_profile_max_deviation_beyond_4d"],
                density_profile_bin_width_m=pk["density_profile_bin_width"], max_overlap_ratio=pk["max_overlap_ratio"],
                fire_iterations=pk["fire_iterations"], **hist)
    counts = pk["neighbour_histogram"]
    n = float(sum(counts))
    share = [k / n for k in counts]
    six = share[6] if len(share) > 6 else 0.0
    others = max(x for k, x in enumerate(share) if k != 6)
    return {"density": fig(pk["packing_density"], 0.63, packing_density_interior=pk["packing_density_interior"]),
            "neighbours": fig(pk["neighbours_mean"], 6.7, neighbour_gap_relative=pk["neighbour_gap_relative"]),
            "eccentric": fig(pk["eccentric_share"], 0.33, **side),
            "branches": fig(pk["neighbours_mean"] * n / 2.0, 3.2 * n, elements=n),
            "six_share": fig(six, 0.25, shares=share),
            "six_mode": fig(max(0.0, others - six), 0.0, largest_other_share=others),
            "isolated": fig(sum(share[:2]), 0.0),
            "tolerance": fig(abs(pk_half["neighbours_mean"] - pk["neighbours_mean"]), 0.0,
                             neighbours_mean_half_tolerance=pk_half["neighbours_mean"])}


PACKING_SRC = "seed 001 §2.1, Figs. 2 and 4: the 5000-element cylinder (r = 1 mm, l = 5 mm), radii +-12.5 %"
PACKING = Case(
    "seed001/packing", ["configs/resistance_cylinder.json"],
    {"fast": {"sizes": [1000], "seeds": [1]}, "full": {"sizes": [5000, 10000, 20000], "seeds": [1, 2, 3]}},
    run_packing,
    [Figure("seed001/packing_density", "density", PACKING_SRC,
            "Eq. 1: N spheres of mean radius r fill 0.63 of the volume (overall solid fraction; band +-0.01). True by "
            "construction: the relax generator rescales the radii to the target fraction", 0.01 / 0.63,
            kind="construction"),
     Figure("seed001/packing_neighbours", "neighbours", PACKING_SRC,
            "Fig. 2: mean neighbour count 6.7 at N = 5000 (neighbours: elements in contact, gap <= 0, issue 58). The "
            "paper is inconsistent here: its 16,000 branches for 5000 elements are 6.4 per element; the branch count "
            "and the text's 'in contact' decide (G1), this figure records the distance to Fig. 2's mean",
            0.03,
            tuned=[{"parameter": "configs/resistance_cylinder.json#neighbour_gap_relative",
                    "why": "0.02 r_mean chosen to give Fig. 2's mean 6.7 on seeds 1-3 at N = 5000 (6.70, 6.75, 6.68): "
                           "this figure is the calibration, not a test"}]),
     Figure("seed001/packing_eccentric", "eccentric", PACKING_SRC,
            "Fig. 4: 33 % of the elements with e >= 0.4 at N = 5000 (band +-3 points); at other N reported "
            "(the surface share falls with N); extra: the interior share (goal <= 5 %) and the wall profile "
            "(goal: within +-0.02 of the interior beyond 4 d)", 0.03 / 0.33),
     Figure("seed001/packing_branches", "branches", PACKING_SRC + ": gate G1 of issue 58",
            "about 16,000 branches (pairs in contact) for 5000 elements (seed 001 L260-261, 271, 604-605): 3.2 N, "
            "band 5 % (16,000 +- 800)", 0.05,
            tuned=[{"parameter": "configs/resistance_cylinder.json#neighbour_gap_relative and touch_tolerance (gap <= 0)",
                    "why": "the contact definition was decided from the text and from this count (issue 58 audit: 16,002 "
                           "at gap <= 0 against 16,814 at 0.02 r_mean, N = 5000): seen, never a pass"}]),
     Figure("seed001/packing_six_share", "six_share", PACKING_SRC + ": gate G1 of issue 58",
            "Fig. 2: about 1200 of 5000 elements with six neighbours: share 0.22-0.28 (0.25 +- 0.03 absolute; set by "
            "issue 58 after the audit had measured 0.225-0.239 on seeds 1-3 at gap <= 0)", 0.03,
            absolute=True),
     Figure("seed001/packing_six_mode", "six_mode", PACKING_SRC + ": gate G1 of issue 58",
            "Fig. 2: six the most common neighbour count: max(0, largest other share - six's share) <= 0.01 "
            "(absolute)", 0.01, absolute=True),
     Figure("seed001/packing_isolated", "isolated", PACKING_SRC + ": gate G1 of issue 58",
            "share of elements with <= 1 neighbour <= 0.5 % (absolute band 0.005)", 0.005, absolute=True),
     Figure("seed001/packing_tolerance", "tolerance", PACKING_SRC + ": gate G2 of issue 58",
            "|mean neighbour count at the relaxation's force tolerance halved - at the config's| < 0.1 (absolute)",
            0.1, absolute=True)])


# ---------------------------------------------------------------- seed 001: Joule-heated rod

def run_joule_rod(ctx):
    from benchmarks.joule_rod import analyze_joule_rod as ajr
    c = ctx.config("configs/joule_rod.json")
    scene = ajr.make_scenario(c, ctx.n, ctx.seed, None, None)
    s = summary(ctx.sparkdem(scene))
    ch = check(s, "uniform_rod_temperature_rise")
    t0 = 293.15
    var = {cap: stage(s, "joule_" + cap)["final"]["heat_temperature_mean"] - t0 for cap in ("sphere", "volume_fraction")}
    r_dem = stage(s, "joule")["final"]["electrical_resistance"]
    st = ajr.joule_stage(scene)
    el, he = st["modules"]["electrical_network"], st["modules"]["heat_conduction"]
    g = ajr.relax_stage(scene)["generator"]
    volume = math.pi * g["radius"] ** 2 * g["length"]
    balance = el["voltage"] ** 2 * st["stop"]["time"] / (r_dem * he["density"] * he["specific_heat"] * volume)
    return {"rise": fig(ch["value"], ch["reference"], rise_capacity_sphere_K=var["sphere"],
                        rise_capacity_volume_fraction_K=var["volume_fraction"], R_dem_ohm=r_dem),
            "balance": fig(ch["value"], balance, R_dem_ohm=r_dem)}


JOULE_ROD = Case(
    "seed001/joule_rod", ["configs/joule_rod.json"],
    {"fast": {"sizes": [1000], "seeds": [1, 2, 3]}, "full": {"sizes": [5000, 10000, 20000], "seeds": [1, 2, 3]}},
    run_joule_rod,
    [Figure("seed001/joule_rod_rise", "rise",
            "seed 001 §3.3, uniform rod, 1 V for 10 ms, adiabatic (GranOO 1.4 %)",
            "dV^2 t / (R_th rho c V), R_th = rho_e (l_d - 2 r_mean)/(pi r_d^2) with r_mean of Eq. 1 for N, "
            "V = pi r_d^2 l_d (cohesive-joule-torsion.md 7.3), written into the scenario before the run", 0.007,
            variants=["heat capacity `sphere` and `volume_fraction` (extra.rise_capacity_*): the config's `domain` "
                      "is the reported figure"]),
     Figure("seed001/joule_rod_energy_balance", "balance",
            "seed 001 §3.3, uniform rod, 1 V for 10 ms, adiabatic (GranOO 1.4 %): the Joule energy balance",
            "dV^2 t / (R rho c V) with the domain's own R (the run's resistance), V = pi r_d^2 l_d: the heat the "
            "network dissipates against the mean rise (issue 58 item 3; the rise against R_th follows the cylinder's "
            "error as 1/(1 + e_cyl) - 1: seed001/joule_rod_rise)", 0.007)])


# ---------------------------------------------------------------- seed 001: pin torsion

def run_torsion(ctx, config="torsion_crack.json"):
    from benchmarks.torsion_crack import run_torsion as rt
    scene = rt.scene_for(os.path.join(REPO, "configs", config), ctx.n, ctx.seed)
    s = summary(ctx.sparkdem(scene))
    out = {}
    for key, name in (("stiffness", "torsion_elastic_stiffness"), ("onset", "torsion_onset_first_break"),
                      ("onset_R", "torsion_onset_resistance_rise"), ("onset_trend", "torsion_onset_from_R")):
        try:
            ch = check(s, name)
            out[key] = fig(ch["value"], ch["reference"])
        except KeyError:
            pass  # no break before the end of the twist: the figure is missing from this run
    final = [st for st in s["stages"] if "torsion_twist" in st.get("final", {})][-1]["final"]
    extra = {"jump_twist_rad": final.get("torsion_resistance_jump_twist"),  # R/R0 >= 2 (1 mrad persistence)
             "separation_twist_rad": final.get("torsion_separation_twist"),
             "R_ratio_at_0.07": final.get("torsion_resistance_ratio_at_0.07"),
             "rejected_rises": final.get("torsion_resistance_rejected_rises"),
             "bonds_broken": final.get("bonds_broken")}
    extra = {k: (math.nan if v is None else v) for k, v in extra.items()}  # null in summary.json: not reached
    if extra["separation_twist_rad"] <= 0.07:
        extra["R_ratio_at_0.07"] = math.inf  # separated by then: no path, R infinite
    if "onset" in out and config == "torsion_crack.json":
        out["onset"]["extra"] = dict(extra, **tension_beams_variant(out))
    elif "onset" in out:
        out["onset"]["extra"] = extra
    if "onset_trend" in out and "onset" in out:  # the detected onset against this run's first break
        out["trend_vs_break"] = fig(out["onset_trend"]["measured"], out["onset"]["measured"])
    return out


def run_torsion_contact(ctx):
    return run_torsion(ctx, "torsion_contact.json")


def tension_beams_variant(out):
    """The figures the beams of the earlier protocol would give (configs/materials/cast_iron_beams.json:
    E_mu and radius ratio of the tension calibration, strength of the bending one), from this run.
    The radius ratio is the same, and before the first break the lattice is linear in E_mu: the
    torque scales with E_mu and the first-break twist with strength / E_mu."""
    ten = load_json(os.path.join(REPO, "configs", "materials", "cast_iron_beams.json"))
    tor = load_json(os.path.join(REPO, "configs", "materials", "cast_iron_beams_torsion.json"))
    e, s = ten["young_modulus"] / tor["young_modulus"], ten["strength"] / tor["strength"]
    v = {"onset_error_tension_bending_beams": out["onset"]["measured"] * s / e / out["onset"]["reference"] - 1.0}
    if "stiffness" in out:
        v["stiffness_error_tension_bending_beams"] = out["stiffness"]["measured"] * e / out["stiffness"]["reference"] - 1.0
    return v


TORSION_SRC = "seed 001 §4, grey cast-iron pin r = 1 mm, L = 5 mm, G = 48.062 GPa, tau_y = 400 MPa"
TORSION_CAL = ("seed 001 section 4's protocol (issue 38 item 3): E_mu fitted so that the pin's torque-twist slope equals "
               "G J / L at N = 5000 and the strength so that the first bond breaks at tau_y L / (G r), on calibration packing "
               "seeds 101-105 that no record uses (benchmarks/beam_calibration/torsion.py, "
               "configs/materials/cast_iron_beams_torsion.calibration.json); the radius ratio is the tension calibration's "
               "(configs/calibration/cast_iron.json, nu_M = 0.29). Validation: seeds 1-5 at every N")
# Until issue 38 (records before 2026-11-28) the beams were calibrated on other stress states: E_mu and
# the radius ratio in tension (4,000 elements), the strength in pure bending; extra.*_tension_bending_beams
# gives those beams' figures from each run.
# The strength was moved from the tension to the bending calibration after one N = 2500 pin run with the
# tension strength (seed 1: first break +14.8 %) - the ledger's rebase of 2026-11-25 23:13 says so.
TORSION_TUNED = [{"parameter": "configs/materials/cast_iron_beams.json#/strength",
                  "why": "the beam strength moved from the tension calibration (46.19 GPa) to the bending one (38.76 GPa) "
                         "after one N = 2500 pin run with the tension strength (seed 1: first break +14.8 %) (rebase of "
                         "2026-11-25 23:13; marked by issue 34)"}]
TORSION = Case(
    "seed001/torsion", ["configs/torsion_crack.json", "configs/materials/cast_iron_beams_torsion.json"],
    # fast: N = 600 (N = 1000 took 25 s here and 36 s in a fresh CI, above the 30 s limit of a CI test)
    {"fast": {"sizes": [600], "seeds": [1]}, "full": {"sizes": [2500, 5000, 10000, 20000], "seeds": [1, 2, 3, 4, 5]}},
    run_torsion,
    [Figure("seed001/torsion_stiffness", "stiffness", TORSION_SRC,
            "torque / (G J theta / L) = 1 before the first break (closed form)", 0.03, calibrated_on=TORSION_CAL),
     Figure("seed001/torsion_onset", "onset", TORSION_SRC,
            "theta = tau_y L / (G r) = 0.0416 rad (VALIDATION.md): twist at the first broken bond", 0.05,
            calibrated_on=TORSION_CAL, tuned=TORSION_TUNED,
            variants=["the beams of the earlier protocol (E_mu in tension, strength in bending: configs/materials/"
                      "cast_iron_beams.json; extra.onset_error_tension_bending_beams and stiffness_error_tension_bending_beams: "
                      "the run's figures scaled by the E_mu and strength ratios, exact before the first break)",
                      "extra: twists of R doubling (jump_twist_rad) and separation, R/R0 at 0.07 rad, resistance "
                      "crossings rejected by the 1 mrad persistence filter"]),
     Figure("seed001/torsion_onset_resistance", "onset_R", TORSION_SRC,
            "theta = tau_y L / (G r) = 0.0416 rad: first twist where R/R0 - 1 > 1 % (the seed's detection)", 0.05,
            calibrated_on=TORSION_CAL, tuned=TORSION_TUNED)])


TORSION_CONTACT_CAL = ("seed 001 section 4's protocol at gap <= 0 (issue 58 item 4): E_mu fitted so that the pin's "
                      "torque-twist slope equals G J / L at N = 5000 and the strength so that the first bond breaks at "
                      "tau_y L / (G r), on calibration packing seeds 101-105 that no record uses "
                      "(benchmarks/beam_calibration/torsion.py --config configs/torsion_contact.json; "
                      "configs/materials/cast_iron_beams_torsion_contact.calibration.json), fixed before any onset run; "
                      "the radius ratio is the tension calibration's. Validation: seeds 1-5 up to N = 10,000, 1-3 at 20,000")
TREND_CAL = ("the detector's constants (fit span 0.02 rad, 5 residual deviations, floor 1e-6, persistence 1 mrad) fixed on "
             "calibration seeds 101-105 at N = 5000 before any validation run (benchmarks/torsion_crack/trend_calibration.json)")
TORSION_CONTACT = Case(
    "seed001/torsion_contact", ["configs/torsion_contact.json", "configs/materials/cast_iron_beams_torsion_contact.json"],
    # fast at N = 600: N = 1000 took 28 s in a fresh CI, at its 30 s limit
    {"fast": {"sizes": [600], "seeds": [1]}, "full": {"sizes": [2500, 5000, 10000, 20000], "seeds": [1, 2, 3, 4, 5]}},
    run_torsion_contact,
    [Figure("seed001/torsion_contact_stiffness", "stiffness", TORSION_SRC + "; beams between elements in contact",
            "torque / (G J theta / L) = 1 before the first break (closed form)", 0.03, calibrated_on=TORSION_CONTACT_CAL),
     Figure("seed001/torsion_contact_first_break", "onset", TORSION_SRC + "; beams between elements in contact",
            "theta = tau_y L / (G r) = 0.0416 rad (VALIDATION.md): twist at the first broken bond", 0.05,
            calibrated_on=TORSION_CONTACT_CAL,
            variants=["extra: twists of R doubling (jump_twist_rad) and separation, R/R0 at 0.07 rad"]),
     Figure("seed001/torsion_contact_onset_from_R", "onset_trend", TORSION_SRC + "; crack detection from R (issue 58 "
            "item 5)", "theta = tau_y L / (G r) = 0.0416 rad against the first persistent departure of R/R0 from its "
            "elastic trend (torsion_test resistance_trend_*)", 0.05, calibrated_on=TORSION_CONTACT_CAL + "; " + TREND_CAL,
            shares_values_with=["seed001/torsion_contact_first_break"]),  # the network is re-solved at each break
     Figure("seed001/torsion_contact_onset_from_R_vs_break", "trend_vs_break", TORSION_SRC + "; crack detection from R",
            "the same run's first broken bond (the detector against the crack it must see): within 5 %", 0.05,
            calibrated_on=TREND_CAL),
     Figure("seed001/torsion_contact_onset_R1pct", "onset_R", TORSION_SRC + "; beams between elements in contact",
            "theta = tau_y L / (G r) = 0.0416 rad: first twist where R/R0 - 1 > 1 % (the earlier detection, reported)",
            0.05, calibrated_on=TORSION_CONTACT_CAL)])


# ---------------------------------------------------------------- seed 001: beam elasticity

def run_beam_elastic(ctx, beams_file="cast_iron_beams.json", contact=False):
    """The tension test of the beam calibration (configs/calibration/cast_iron_tension.json) with the
    committed beams (strength 1e30: nothing breaks), as benchmarks/beam_calibration/run.sh.
    contact: neighbours and beams between elements in contact (gap <= 0, issue 58)."""
    c = ctx.config("configs/calibration/cast_iron_tension.json")
    beams = load_json(os.path.join(REPO, "configs", "materials", beams_file))
    if contact:
        c["stages"][0]["generator"]["neighbour_gap_relative"] = 0.0
        next(st for st in c["stages"] if "create_bonds" in st)["create_bonds"] = {"gap_tolerance_relative": 0.0}
    c["seed"] = ctx.seed
    c["bonds"]["params"] = dict(beams, strength=1e30)
    c["stages"][0]["generator"]["particles"] = ctx.n
    s = summary(ctx.sparkdem(c))
    h = stage(s, "hold")["final"]
    pk = stage(s, "cook")["packing"]
    side = dict(bonds_per_element=2.0 * h["bonds"] / ctx.n, packing_density_interior=pk["packing_density_interior"],
                criterion_to_tension_stress=h["bonds_max_failure_stress"] / h["tension_stress"])
    return {"E": fig(h["tension_young_modulus"], 124e9, **side), "nu": fig(h["tension_poisson_ratio"], 0.29)}


BEAM_SRC = ("issue 20 step 1: grey cast iron E = 124 GPa, nu = 0.29 (seed 001 §4) of a bonded sample r = 1 mm, "
            "L = 4 mm packed and bonded as the pin, quasi-static tension")
BEAM_CAL = ("radius_ratio and E_mu by `sparkdem calibrate configs/calibration/cast_iron.json` on this scene at "
            "N = 4000, seed 1 (configs/materials/cast_iron_beams.calibration.json): the N = 4000 records hold "
            "that calibration run itself; the other N and seeds test its transfer")
BEAM = Case(
    "seed001/beam_elastic", ["configs/calibration/cast_iron_tension.json", "configs/materials/cast_iron_beams.json"],
    {"fast": {"sizes": [1000], "seeds": [1]}, "full": {"sizes": [2500, 4000, 5000, 10000], "seeds": [1, 2, 3]}},
    run_beam_elastic,
    [Figure("seed001/beam_E_M", "E", BEAM_SRC, "E_M = 124 GPa (the calibration target)", 0.03, calibrated_on=BEAM_CAL,
            calibration_sizes=[4000]),
     Figure("seed001/beam_nu_M", "nu", BEAM_SRC, "nu_M = 0.29 (the calibration target)", 0.03, calibrated_on=BEAM_CAL,
            calibration_sizes=[4000])])


def run_beam_elastic_contact(ctx):
    return run_beam_elastic(ctx, "cast_iron_beams_torsion_contact.json", contact=True)


BEAM_CONTACT = Case(
    "seed001/beam_elastic_contact", ["configs/calibration/cast_iron_tension.json",
                                     "configs/materials/cast_iron_beams_torsion_contact.json"],
    {"full": {"sizes": [2500, 5000, 10000], "seeds": [1, 2, 3]}},
    run_beam_elastic_contact,
    [Figure("seed001/beam_contact_E_M", "E", BEAM_SRC + "; beams between elements in contact, calibrated in torsion",
            "E_M = 124 GPa: the torsion calibration's transfer to tension (VALIDATION.md, elastic torsion: E_M, nu_M "
            "as a transfer test; cases.run_beam_elastic_contact bonds at gap <= 0)", 0.03,
            calibrated_on=TORSION_CONTACT_CAL),
     Figure("seed001/beam_contact_nu_M", "nu", BEAM_SRC + "; beams between elements in contact, calibrated in torsion",
            "nu_M = 0.29: the transfer to tension of the radius ratio (the tension calibration's at 0.02 r_mean)", 0.03,
            calibrated_on=TORSION_CONTACT_CAL)])


# ---------------------------------------------------------------- seed 001: thick plate

def run_plate(ctx):
    c = ctx.config("configs/plate_source.json")
    c["seed"] = ctx.seed
    c["stages"][0]["generator"]["particles"] = ctx.n
    out = ctx.sparkdem(c)
    with open(os.path.join(ctx.rundir, "scene.json"), "w") as f:  # bench_plate reads RUN/scene.json, RUN/out
        json.dump(c, f, indent=1)
    csv_path = os.path.join(ctx.rundir, "plate.csv")
    # The fast tier takes the FD reference from coarser grids (60-240 instead of 240-960 in the
    # Richardson step: about 1 s instead of 35 s); it guards behaviour, the full tier validates.
    grids = ["--fd-grids", "60 120 240"] if ctx.tier == "fast" else []
    ctx.command([ctx.runner.tool("benchmarks/plate_source/bench_plate"), "--csv", csv_path] + grids + [ctx.rundir],
                "bench_plate")
    import csv
    row = next(csv.DictReader(open(csv_path)))
    assert out
    return {p: fig(row["phi_" + p], row["ref_" + p], reference_band=float(row["ref_band_" + p]))
            for p in ("P1", "P2", "P1c")}


PLATE_SRC = "seed 001 §3.2, thick 304L plate with a central 1 V source through the depth (GranOO <= 4.2 %)"
PLATE_REF = ("finite-difference solution of the same 2-D continuum problem (tests/support/fd_laplace2d.hpp: "
             "grids to h = 30/960 mm, Richardson), computed by benchmarks/plate_source/bench_plate")
PLATE = Case(
    "seed001/plate", ["configs/plate_source.json"],
    {"fast": {"sizes": [1000], "seeds": [1]}, "full": {"sizes": [5000, 10000, 20000], "seeds": [1, 2, 3]}},
    run_plate,
    [Figure("seed001/plate_P1", "P1", PLATE_SRC, PLATE_REF + "; P1 = (15, 6) mm, halfway between the ground and the "
            "source's nearest edge (our reading, fixed before the runs)", 0.02,
            variants=["P1c = (15, 7.5) mm, halfway to the source centre: extra figure seed001/plate_P1c"]),
     Figure("seed001/plate_P2", "P2", PLATE_SRC, PLATE_REF + "; P2 = (0, 30) mm, the top-left corner", 0.02),
     Figure("seed001/plate_P1c", "P1c", PLATE_SRC + " (variant reading of P1)", PLATE_REF + "; P1c = (15, 7.5) mm",
            0.02),
     Figure("seed001/plate_P1_granoo", "P1", PLATE_SRC + ": reproduce", PLATE_REF + "; P1 = (15, 6) mm; band: GranOO's "
            "4.2 % (issue 58 item 3: plate P1 within 4.2 %)", 0.042, tiers=["full"])])


# ---------------------------------------------------------------- seed 001: notched rod

def run_notch(ctx):
    c = ctx.config("configs/joule_notch_pack.json")
    c["seed"] = ctx.seed
    only_stage(c, type="relax")["generator"]["particles"] = ctx.n
    pack = ctx.sparkdem(c, "pack")
    # The fast tier's FV reference uses grids 1, 2, 4 (3 s instead of 16 s): on the seed-1 packing at
    # N = 1000 it moves R_eq by 4e-7 and the slab temperature by 4e-6 (relative) from grids 2, 4, 8,
    # with which the fast bands were derived.
    grids = ["--grids", "1,2,4"] if ctx.tier == "fast" else []
    cmp_out = ctx.command([sys.executable, os.path.join(REPO, "tools", "fv_notch", "compare_notch.py"), pack,
                           "--fv", ctx.runner.tool("tools/fv_notch")] + grids, "fv_reference")
    thermal = ctx.command([sys.executable, os.path.join(REPO, "benchmarks", "joule_notch", "thermal_scenario.py"), pack,
                           cmp_out], "thermal_scene")
    with open(thermal) as f:
        scene = json.load(f)
    out = ctx.sparkdem(scene, "thermal")
    rec = ctx.command([sys.executable, os.path.join(REPO, "benchmarks", "joule_notch", "record_thermal.py"), out, cmp_out],
                      "record")
    with open(rec) as f:
        r = json.load(f)
    t0 = 293.15
    return {"R": fig(r["R_dem_ohm"], r["R_fv_ohm"]),
            "rise": fig(r["T_slab_dem_K"] - t0, r["T_slab_fv_K"] - t0, rise_per_power_error_pct=r["rise_per_power_error_pct"])}


NOTCH_SRC = "seed 001 §3.3, notched rod, 1 V for 10 ms (GranOO 9.2 % / about 12 % at N = 5000)"
NOTCH_REF = ("tools/fv_notch finite-volume solve of the same notched geometry (Richardson over three grids), electrode "
             "planes at the end sets' mean heights of each packing, run on the packing before its thermal run "
             "(tools/fv_notch/compare_notch.py)")
NOTCH = Case(
    "seed001/notch", ["configs/joule_notch_pack.json", "configs/joule_notch.json"],
    {"fast": {"sizes": [1000], "seeds": [1]}, "full": {"sizes": [5166, 10332, 20664], "seeds": [1, 2, 3]}},
    run_notch,
    [Figure("seed001/notch_resistance", "R", NOTCH_SRC, NOTCH_REF + ": R_eq; band 4.6 % at N about 5000, 3.5 % at "
            "N >= 20,000 (VALIDATION.md)", {0: 0.046, 20000: 0.035}),
     Figure("seed001/notch_slab_rise", "rise", NOTCH_SRC, NOTCH_REF + ": slab-mean rise |z - 3.5 mm| <= 2 r_mean; band "
            "6 % at N about 5000, 3.5 % at N >= 20,000 (VALIDATION.md)", {0: 0.06, 20000: 0.035}),
     Figure("seed001/notch_resistance_granoo", "R", NOTCH_SRC + ": reproduce", NOTCH_REF + ": R_eq; band: no worse than "
            "GranOO, 9.2 % at every N (VALIDATION.md's reproduce band; issue 58 item 3)", 0.092, tiers=["full"])])


# ---------------------------------------------------------------- seed 000: NiAl SPS conductivity

TABLE1 = {0.216: 4.33e6, 0.164: 6.14e6, 0.106: 7.44e6, 0.050: 8.77e6}


ELEMENT = {"topology": "sphere_element"}
FE_TABLE = {"hemisphere": "fe_table"}


def element_stage(snapshot, gb_thickness, scene, network=ELEMENT):
    """A zero-step stage on `snapshot` with the scene's conductivity module changed by `network`
    (default: the sphere-element topology of issue 21, physics/electrical/sphere_element.hpp; FE_TABLE:
    the hemisphere FE table instead of Eq. 19's linear law), layer thickness gb_thickness [m]."""
    mod = json.loads(json.dumps(only_stage(scene, name="conductivity_no_gb")["modules"]["electrical_network"]))
    mod.update(network, gb_thickness=gb_thickness)
    return {"name": "element", "type": "dynamics", "sets": ["top_electrode", "bottom_electrode"], "from_snapshot": snapshot,
            "dt_fraction": 0.1, "stop": {"steps": 0}, "modules": {"electrical_network": mod}}


def element_kappa(ctx, scene, snapshots, gb_thickness, name, network=ELEMENT):
    """kappa_eff [S/m] of the `network` variant on each snapshot (one scene, a stage each)."""
    c = json.loads(json.dumps(scene))
    c["stages"] = [dict(element_stage(sn, gb_thickness, scene, network), name=f"element_{k}") for k, sn in enumerate(snapshots)]
    out = ctx.sparkdem(c, name=name)
    import csv as _csv
    rows = list(_csv.DictReader(open(os.path.join(out, "timeseries.csv"))))
    return [float(next(r for r in rows if int(r["stage"]) == k)["electrical_conductivity_eff"]) for k in range(len(snapshots))]


def element_figures(ctx, scene, out, at, target_index, network=ELEMENT, tag="element"):
    """The `network` variant on the run's snapshots: without the layer, and with the layer's
    thickness calibrated on snapshot `target_index` (networks.calibrate_thickness, epsilon as in the
    scene) then applied to every snapshot. Returns (no layer, calibrated, delta)."""
    snaps = [os.path.abspath(os.path.join(out, "snapshots", f"hot_press_{k}.h5")) for k in range(len(at))]
    snaps = [sn if os.path.exists(sn) else None for sn in snaps]
    if any(sn is None for sn in snaps):
        return {}, {}, None
    from benchmarks.sps_nial.networks import calibrate_thickness
    bare = element_kappa(ctx, scene, snaps, 0.0, f"{tag}_no_layer", network)
    delta, _ = calibrate_thickness(
        lambda d: element_kappa(ctx, scene, [snaps[target_index]], d, f"{tag}_cal_{math.log(d):.6f}", network)[0],
        TABLE1[at[target_index]])
    cal = element_kappa(ctx, scene, snaps, delta, f"{tag}_calibrated", network)
    return dict(enumerate(bare)), dict(enumerate(cal)), delta


def variant_kappa_figures(ctx, c, out, at, taken, network, tag):
    """Figures {tag}_kappa_P of a network variant on the run's snapshots (calibrated on 0.164)."""
    res = {}
    bare, calibrated, delta = element_figures(ctx, c, out, at, at.index(0.164), network, tag)
    for idx, p in enumerate(at):
        ref = next((k for q, k in TABLE1.items() if abs(q - p) < 1e-9), None)
        if ref is None or idx not in calibrated:
            continue
        hs = KAPPA_B * hs_factor(taken.get(idx, {}).get("value", p))
        res[f"{tag}_kappa_{p:.3f}"] = fig(calibrated[idx], ref, porosity_taken=taken.get(idx, {}).get("value"),
                                          kappa_without_layer=bare.get(idx), delta_gb_calibrated_m=delta,
                                          hashin_shtrikman_bound_mass_porosity=hs,
                                          kappa_without_layer_over_bound=bare.get(idx, float("nan")) / hs)
    return res


def run_nial(config, element=False, fe_table=False):
    def run(ctx):
        from tools import sps_outputs as so
        c = ctx.config(config)
        c["seed"] = ctx.seed
        # The reduced pipeline's last stage (cooled_conductivity, 100,000 steps) comes after the
        # conductivity sweeps the figures read, so the fast tier leaves it out: same figures, a third
        # of the run time.
        c["stages"] = [st for st in c["stages"] if st["name"] != "cooled_conductivity"]
        out = ctx.sparkdem(c)
        s = summary(out)
        taken = {t["index"]: t for t in so.find_stage(s, "hot_press").get("snapshots", {}).get("taken", [])}
        at = only_stage(c, name="hot_press")["snapshots"]
        at = at["at"] if isinstance(at, dict) else at
        gb, nogb = so.sweep_values(s, "conductivity_gb"), so.sweep_values(s, "conductivity_no_gb")
        cal = so.calibration(s, "conductivity_gb") or {}
        uniform = so.uniform_press_gates(out, s)
        res = {}
        for idx, p in enumerate(at):
            ref = next((k for q, k in TABLE1.items() if abs(q - p) < 1e-9), None)
            if ref is None or idx not in gb:
                continue
            gates = {f"qs_{k}": v for k, v in so.quasi_static_gates(taken.get(idx, {}).get("columns", {})).items()
                     if v is not None and not k.endswith("_pass")}
            gates.update({f"u_{k}": v for k, v in uniform.get(idx, {}).items() if v is not None and not k.endswith("_pass")})
            if uniform.get("median_rises") is not None:
                gates["u_g4_median_rises"] = float(uniform["median_rises"])
            res[f"kappa_{p:.3f}"] = fig(gb[idx], ref, porosity_taken=taken.get(idx, {}).get("value"),
                                        kappa_without_layer=nogb.get(idx), delta_gb_calibrated_m=cal.get("value"), **gates)
        if element and 0.164 in at:
            res.update(variant_kappa_figures(ctx, c, out, at, taken, ELEMENT, "element"))
        if fe_table and 0.164 in at:
            res.update(variant_kappa_figures(ctx, c, out, at, taken, FE_TABLE, "fe_table"))
        return res
    return run


def affine_stage(scene, snapshot, scale, origin, gb_thickness, name):
    """A zero-step stage on the packed `snapshot` mapped by `affine` (engine/state/affine_map.hpp),
    with the scene's no-layer network (layer thickness gb_thickness [m]) and its compact monitor."""
    mod = json.loads(json.dumps(only_stage(scene, name="conductivity_no_gb")["modules"]["electrical_network"]))
    mod["gb_thickness"] = gb_thickness
    return {"name": name, "type": "dynamics", "sets": ["top_electrode", "bottom_electrode"], "from_snapshot": snapshot,
            "affine": {"scale": list(scale), "origin": list(origin)}, "dt_fraction": 0.1, "stop": {"steps": 0},
            "modules": {"electrical_network": mod}, "compact": only_stage(scene, name="hot_press")["compact"]}


def affine_rows(ctx, scene, snapshot, scales, origin, gb_thickness, name):
    """The last time-series row of each affine stage (one scene, a stage per scale)."""
    c = json.loads(json.dumps(scene))
    c["stages"] = [affine_stage(scene, snapshot, sc, origin, gb_thickness, f"affine_{k}") for k, sc in enumerate(scales)]
    import numpy as np
    from tools import sps_outputs as so
    ts = so.timeseries(ctx.sparkdem(c, name=name))
    last = [int(np.flatnonzero(ts["stage"] == q)[-1]) for q in range(len(scales))]
    return [{col: float(v[i]) for col, v in ts.items()} for i in last]


AFFINE_GATE_EXTRAS = ("g1_density_ratio_rise", "g2_envelope_p995_over_die", "g4_network_neck_last_bin_percent",
                      "network_neck_max_bin_percent", "network_neck_median_a_over_rmin", "network_neck_gbf_bound_share")


def run_nial_affine(ctx):
    """Issue 59's uniform references: the packed state of sps_nial.json (its pack stage, this seed)
    densified by an affine map to each of Table 1's porosities by mass, isotropically (positions,
    die and punches x s about the die axis on the lower punch, s^3 = (1 - p0) / (1 - p)) and
    uniaxially (heights x (1 - p0) / (1 - p)), through the main scenario's network (no layer; the
    layer's thickness calibrated on 0.164 as there). No press: what a uniform microstructure of
    this packing gives. p0: the packed state's own porosity by mass (first pass)."""
    from benchmarks.sps_nial.networks import calibrate_thickness
    from tools import sps_outputs as so
    c = ctx.config("configs/sps_nial.json")
    c["seed"] = ctx.seed
    packed = json.loads(json.dumps(c))
    packed["stages"] = [c["stages"][0]]
    snap = os.path.abspath(os.path.join(ctx.sparkdem(packed, name="packed"), "final_state.h5"))
    import h5py
    with h5py.File(snap, "r") as f:
        bottom = f["state/walls/bottom/geometry"][()][0]
        die = f["state/walls/die/geometry"][()][0]
        u_bottom = float(f["state/walls/bottom/u"][()])
    origin = [die[0], die[1], bottom[2] + u_bottom * bottom[5]]
    p0 = affine_rows(ctx, c, snap, [[1.0, 1.0, 1.0]], origin, 0.0, "packed_porosity")[0]
    targets = sorted(TABLE1, reverse=True)
    res = {}
    for mode in ("isotropic", "uniaxial"):
        ratio = [(1.0 - p0["porosity_mass"]) / (1.0 - p) for p in targets]
        scales = [[r ** (1 / 3)] * 3 if mode == "isotropic" else [1.0, 1.0, r] for r in ratio]
        bare = affine_rows(ctx, c, snap, scales, origin, 0.0, f"{mode}_no_layer")
        k_cal = targets.index(0.164)
        delta, _ = calibrate_thickness(lambda d: affine_rows(ctx, c, snap, [scales[k_cal]], origin, d,
                                                             f"{mode}_cal_{math.log(d):.6f}")[0]["electrical_conductivity_eff"],
                                       TABLE1[0.164])
        cal = affine_rows(ctx, c, snap, scales, origin, delta, f"{mode}_calibrated")
        packing_ratio = so.density_ratio(p0)
        rises = so.median_rises([r["network_neck_median_a_over_rmin"] for r in bare])
        for k, p in enumerate(targets):
            b = bare[k]
            g = so.uniform_gate_values(b, b, packing_ratio, b["envelope_p995_radius"] / b["die_radius"])
            if g["g1_density_ratio_rise"] is None:
                raise ValueError(f"nial_affine: no interior porosity at {mode} {p} (the compact's interior is empty)")
            gates = {f"u_{key}": g[key] for key in AFFINE_GATE_EXTRAS}
            res[f"{mode}_kappa_{p:.3f}"] = fig(
                cal[k]["electrical_conductivity_eff"], TABLE1[p], porosity_taken=b["porosity_mass"], packing_porosity=p0["porosity_mass"],
                scale=scales[k][2], kappa_without_layer=b["electrical_conductivity_eff"], delta_gb_calibrated_m=delta,
                kappa_without_layer_over_bound=b["electrical_conductivity_eff"] / (KAPPA_B * hs_factor(b["porosity_mass"])),
                **gates, u_g4_median_rises=float(rises))
    return res


NIAL_SRC = "seed 000 (NiAl SPS), Table 1: effective conductivity of the measured samples, evaluated cold"
NIAL_REF = "measured kappa of seed 000 Table 1; L and A from the snapshot (Eq. 28 as written: sample height, die section)"
NIAL_CAL = "grain-boundary layer epsilon/delta_gb on the porosity 0.164 snapshot only (kappa = 6.14e6 S/m)"
NIAL_TUNED = [{"parameter": "configs/sps_nial.json#/stages/1/walls/top/max_speed, /stages/2/walls/top/max_speed",
               "why": "punch servo speed limit raised to 0.05 m/s so the punch follows the pressure, chosen after "
                      "seeing the densification of earlier runs (issue 18)"}]
NIAL = Case(
    "seed000/nial", ["configs/sps_nial.json"],
    {"full": {"sizes": [17876], "seeds": [2024, 2025, 2026]}},
    run_nial("configs/sps_nial.json", element=True, fe_table=True),
    [Figure(f"seed000/nial_kappa_{p:.3f}", f"kappa_{p:.3f}", NIAL_SRC + "; the paper's network (Eq. 19 reading A)",
            NIAL_REF + f" at porosity {p}", 0.05,
            calibrated_on=NIAL_CAL, tuned=NIAL_TUNED,
            variants=["without the grain-boundary layer (extra.kappa_without_layer)",
                      "quasi-static gates of the snapshot (issue 36; extra.qs_*: kinetic energy / punch work <= 1e-4, core - compact "
                      "mass porosity within 0.02, envelope / die radius >= 0.99, fullest neck bin <= 25 %; tools/sps_outputs.GATES)",
                      "uniform-press gates of the snapshot (issue 59; extra.u_*: G1 interior / whole relative density by mass "
                      "rises <= 2 % over the packing's, G2 99.5th percentile of axis distance + radius >= 0.99 die radius, G4 "
                      "the network's necks: last bin <= 25 %, median rising over the snapshots; tools/sps_outputs.UNIFORM_GATES)"])
     for p in (0.216, 0.106, 0.050)]
    + [Figure(f"seed000/nial_fe_table_kappa_{p:.3f}", f"fe_table_kappa_{p:.3f}",
              NIAL_SRC + "; hemisphere FE table instead of Eq. 19 (an option beside the paper's law, issue 59)",
              NIAL_REF + f" at porosity {p}", 0.05, calibrated_on=NIAL_CAL + ", for the FE-table network",
              tuned=NIAL_TUNED,
              variants=["without the grain-boundary layer (extra.kappa_without_layer, its ratio to the Hashin-Shtrikman bound at "
                        "the mass porosity in extra.kappa_without_layer_over_bound)"])
       for p in (0.216, 0.106, 0.050)]
    + [Figure(f"seed000/nial_element_kappa_{p:.3f}", f"element_kappa_{p:.3f}", NIAL_SRC + "; sphere-element network (issue 21)",
              NIAL_REF + f" at porosity {p}", 0.05, calibrated_on=NIAL_CAL + ", for the sphere-element network",
              tuned=NIAL_TUNED,
              variants=["without the grain-boundary layer (extra.kappa_without_layer, its ratio to the Hashin-Shtrikman bound at "
                        "the mass porosity in extra.kappa_without_layer_over_bound)"])
       for p in (0.216, 0.106, 0.050)])
NIAL_AFFINE_SRC = ("issue 59 item 4: the packed state of configs/sps_nial.json densified by an affine map to the porosity by "
                   "mass, through the main scenario's network (the paper's, Eq. 19 reading A; layer calibrated on 0.164): a "
                   "uniform microstructure's answer, no press (cases.run_nial_affine)")
NIAL_AFFINE = Case(
    "seed000/nial_affine", ["configs/sps_nial.json"],
    {"full": {"sizes": [17876], "seeds": [2024, 2025, 2026]}},
    run_nial_affine,
    [Figure(f"seed000/nial_affine_{mode}_kappa_{p:.3f}", f"{mode}_kappa_{p:.3f}", NIAL_AFFINE_SRC + f"; {mode} map",
            NIAL_REF + f" at porosity {p}", 0.05, calibrated_on=NIAL_CAL + f", for the {mode} map", kind="construction",
            variants=["without the layer (extra.kappa_without_layer, over the Hashin-Shtrikman bound: "
                      "extra.kappa_without_layer_over_bound); the uniform-press gates of the mapped state (extra.u_*)"])
     for mode in ("isotropic", "uniaxial") for p in (0.216, 0.106, 0.050)])
NIAL_SMALL = Case(
    "seed000/nial_small", ["configs/sps_nial_small.json"],
    {"fast": {"sizes": [300], "seeds": [1]}},
    run_nial("configs/sps_nial_small.json"),
    [Figure(f"seed000/nial_small_kappa_{p:.3f}", f"kappa_{p:.3f}", NIAL_SRC + " (reduced compact, regression only)",
            NIAL_REF + f" at porosity {p}", 0.05, calibrated_on=NIAL_CAL) for p in (0.216, 0.106, 0.050)])


# ---------------------------------------------------------------- seed 000: Table 1 densification

def run_table1_densification(ctx, quasi_static=False):
    """benchmarks/sps_table1/predict.py: D_0 calibrated on sample 2, samples 1, 3, 4 predicted (the hot
    press on the inertia-free path from 60 s above the sintering start when quasi_static)."""
    from benchmarks.sps_table1 import predict
    prepare = predict.preparer(quasi_static)
    result, d0, history = predict.predict(lambda sc, name: ctx.sparkdem(prepare(sc), name), ctx.seed, log=lambda m: None)
    out = {}
    for k, r in result.items():
        if r.get("failed"):
            continue
        out[f"porosity_sample{k}"] = fig(r["porosity_envelope"], r["measured"], d0_calibrated_m2_s=d0,
                                         porosity_mass_in_die=r["porosity_mass"],
                                         porosity_mass_hold_end=r["porosity_mass_hold_end"],
                                         envelope_radius_m=r["envelope_radius_m"], calibration_runs=len(history))
    return out


T1_SRC = "seed 000 (NiAl SPS), Table 1: porosity of samples hot pressed along their own cycles (issue 21 item 7)"
T1_REF = ("measured porosity of seed 000 Table 1; simulated: porosity by mass in the cooled sample's own envelope "
          "(compact monitor porosity_envelope, caliper cells of 3 mean diameters), reduced compact (~300 particles)")
T1_CAL = ("grain-boundary diffusion prefactor D_0 (within 2e-6..2 m^2/s) on sample 2 (1300 C, 5 MPa, 0.164) of the "
          "same packing seed, to 0.002")
TABLE1_DENSIFICATION = Case(
    "seed000/table1_densification", [f"configs/sps_table1_sample{k}.json" for k in (1, 2, 3, 4)],
    {"full": {"sizes": [300], "seeds": [2024, 2025, 2026]}},
    run_table1_densification,
    [Figure(f"seed000/table1_porosity_sample{k}", f"porosity_sample{k}", T1_SRC, T1_REF + f", sample {k}", 0.02,
            calibrated_on=T1_CAL, absolute=True,
            variants=["porosity by mass in the die after cooling (extra.porosity_mass_in_die) and at the end of the "
                      "hold (extra.porosity_mass_hold_end)"])
     for k in (1, 3, 4)])

TABLE1_DENSIFICATION_QS = Case(
    "seed000/table1_densification_quasi_static",
    [f"configs/sps_table1_sample{k}.json" for k in (1, 2, 3, 4)] + ["benchmarks/sps_nial/issue36/sps_nial_small_quasi_static_mean.json"],
    {"full": {"sizes": [300], "seeds": [2024, 2025, 2026]}},
    lambda ctx: run_table1_densification(ctx, quasi_static=True),
    [Figure(f"seed000/table1_porosity_sample{k}_quasi_static", f"porosity_sample{k}", T1_SRC,
            T1_REF + f", sample {k}; hot press inertia-free (issue 36 item 1) from 60 s above the sintering start, "
            "neck_stiffness neck_radius, necks resisting relative rotation", 0.02,
            calibrated_on=T1_CAL, absolute=True,
            variants=["porosity by mass in the die after cooling (extra.porosity_mass_in_die) and at the end of the "
                      "hold (extra.porosity_mass_hold_end)"])
     for k in (1, 3, 4)])


# ---------------------------------------------------------------- seed 002: percolation of fillers

def run_cpc(config, n_seeds):
    def run(ctx):
        import csv as _csv
        c = ctx.config(config)
        k = n_seeds if ctx.tier == "full" else max(1, n_seeds // 2)  # configurations per phi and ensemble
        base = (ctx.seed - 1) * k
        for st in c["stages"]:
            st["sweep"]["seeds"] = list(range(base + 1, base + k + 1))
        out = ctx.sparkdem(c)
        prefix = os.path.join(ctx.rundir, "fit")
        ctx.command([sys.executable, os.path.join(REPO, "tools", "plot_cpc.py"), "analyse", out, "--prefix", prefix],
                    "fit")
        for d in glob.glob(os.path.join(out, "sweep_*", "[0-9]*")):  # the item directories are large
            import shutil
            shutil.rmtree(d, ignore_errors=True)
        row = next(_csv.DictReader(open(prefix + "_fits.csv")))
        return {"phi_c": fig(row["phi_c"], PHI_C[config], phi_c_err=float(row["phi_c_err"])),
                "t": fig(row["t"], 2.07, t_err=float(row["t_err"]), t_points=int(row["t_points"]))}
    return run


PHI_C = {"configs/cpc_percolation.json": 0.235, "configs/cpc_percolation_t_grid.json": 0.235, "configs/cpc_percolation_segregated.json": 0.04,
         "configs/cpc_percolation_segregated_radius.json": 0.04}
CPC_SRC = "seed 002 (Barbieri et al.), percolation of rigid fillers in a cube of L = 70 R"
CPC = Case(
    "seed002/cpc_uniform", ["configs/cpc_percolation.json"],
    {"fast": {"sizes": [0], "seeds": [1]}, "full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_cpc("configs/cpc_percolation.json", 10),
    [Figure("seed002/phi_c_uniform", "phi_c", CPC_SRC + ", uniform",
            "phi_c = 23.5 % (paper); band ±1.5 points = ±6.4 % relative; sigmoid fit of the spanning probability "
            "(tools/plot_cpc.py), 10 configurations per phi per ensemble", 0.064, min_seeds=3),
     Figure("seed002/t_exponent", "t", CPC_SRC + ", uniform",
            "t = 2.07 (paper); band ±0.1 = ±4.8 % relative; fit range phi - phi_c in [0.01, 0.12] (issue 22's range, "
            "the tools/plot_cpc.py default since stop 30; before: >= 0.005, whose t and that of >= 0.02 had been seen)",
            0.048, min_seeds=3)])
# Issue 39 item 4: the t scatter across ensembles (6.8 %) stays above its 4.8 % band with 10
# configurations per phi: the same fit (range fixed in issue 22) on 30 configurations per phi per
# ensemble (ensembles 1-3 use configurations 1-30, 31-60, 61-90).
CPC_POOLED = Case(
    "seed002/cpc_uniform_30", ["configs/cpc_percolation.json"],
    {"full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_cpc("configs/cpc_percolation.json", 30),
    [Figure("seed002/t_exponent_30", "t", CPC_SRC + ", uniform, 30 configurations per phi per ensemble",
            "t = 2.07 (paper); band ±0.1 = ±4.8 % relative; fit range phi - phi_c in [0.01, 0.12] (issue 22's range)",
            0.048, min_seeds=3)])
# Issue 60 item 5: the same fit on a finer phi grid (11 points inside the fit range instead of the 5
# of configs/cpc_percolation.json), 30 configurations per phi per ensemble as cpc_uniform_30; the
# reference and band fixed before the run (those of t_exponent_30).
CPC_T_GRID = Case(
    "seed002/cpc_uniform_t_grid", ["configs/cpc_percolation_t_grid.json"],
    {"full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_cpc("configs/cpc_percolation_t_grid.json", 30),
    [Figure("seed002/t_exponent_t_grid", "t", CPC_SRC + ", uniform, 30 configurations per phi per ensemble, 18 phi "
            "(11 inside the fit range)",
            "t = 2.07 (paper); band ±0.1 = ±4.8 % relative; fit range phi - phi_c in [0.01, 0.12] (issue 22's range)",
            0.048, min_seeds=3)])
CPC_SEG = Case(
    "seed002/cpc_segregated", ["configs/cpc_percolation_segregated.json"],
    {"full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_cpc("configs/cpc_percolation_segregated.json", 8),
    [Figure("seed002/phi_c_segregated", "phi_c", CPC_SRC + ", segregated (lambda = 35)",
            "phi_c about 4 % (paper); band ±1 point = ±25 % relative", 0.25, min_seeds=3,
            tuned=[{"parameter": "configs/cpc_percolation_segregated.json#aggregation_lambda",
                    "why": "lambda = 35 read in diameters (70 R) after seeing phi_c = 13.1 % with the reading in radii "
                           "(issue 18, issue 22)"}])])
CPC_SEG_R = Case(
    "seed002/cpc_segregated_radius", ["configs/cpc_percolation_segregated_radius.json"],
    {"full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_cpc("configs/cpc_percolation_segregated_radius.json", 8),
    [Figure("seed002/phi_c_segregated_radius", "phi_c", CPC_SRC + ", segregated (lambda = 35 R: the SM's reading)",
            "phi_c about 4 % (paper); band ±1 point = ±25 % relative. The reading of lambda is the text's: the SM's "
            "algorithm (S2: d_C(r_j) < lambda R, 'R being the radius of the particle'), Fig. S3's caption and Fig. 1's "
            "caption ('lambda in units of the sphere radius') against the main text's lambda D; decided in stop 30 "
            "from the text, after both readings had been run (issue 18)", 0.25, min_seeds=3)])


# ---------------------------------------------------------------- seed 002: switching strain (bonded network)

def run_switch_bonded(ctx):
    import csv as _csv
    c = ctx.config("configs/cpc_ptc_strain.json")
    k = len(c["stages"][0]["sweep"]["seeds"])  # configurations per ensemble (the config's 4)
    for st in c["stages"]:
        st["sweep"]["seeds"] = list(range((ctx.seed - 1) * k + 1, ctx.seed * k + 1))
    out = ctx.sparkdem(c)
    res = {}
    for st in c["stages"]:
        lam = st["generator"].get("aggregation_lambda", 0)
        rows = list(_csv.DictReader(open(os.path.join(out, f"sweep_{st['name']}.csv"))))
        eps = [float(r["ptc_strain_switching_strain"]) for r in rows if r["status"] == "completed"]
        if eps:
            res["uniform" if lam == 0 else "segregated"] = fig(sum(eps) / len(eps), SWITCH[lam == 0],
                                                               configurations=len(eps))
    return res


SWITCH = {True: 0.0315, False: 0.0285}
SWITCH_SRC = "seed 002, switching strain of the composite at phi = 25 %, L = 70 R"
SWITCH_TUNED = [{"parameter": "configs/cpc_ptc_strain.json#min_gap (h_min = 0.1 R)",
                 "why": "the bonded network's switching strain is set by h_min (19 / 2.3 / 0.9 % at 0.01 / 0.1 / 0.5 R); "
                        "0.1 R was kept after seeing those values (issue 18, issue 22)"}]
SWITCH_BONDED = Case(
    "seed002/switch_bonded", ["configs/cpc_ptc_strain.json"],
    {"full": {"sizes": [0], "seeds": [1, 2, 3]}},
    run_switch_bonded,
    [Figure("seed002/switch_strain_bonded_uniform", "uniform", SWITCH_SRC + ", uniform, bonded-spring matrix "
            "(the note's minimum model, not the paper's RKPM continuum)", "3.15 % (paper), band 10 % (VALIDATION.md)",
            0.10, tuned=SWITCH_TUNED),
     Figure("seed002/switch_strain_bonded_segregated", "segregated", SWITCH_SRC + ", segregated (lambda = 70 R), "
            "bonded-spring matrix", "2.85 % (paper), band 10 % (VALIDATION.md)", 0.10,
            tuned=SWITCH_TUNED + [{"parameter": "configs/cpc_ptc_strain.json#aggregation_lambda",
                                   "why": "lambda = 35 read in diameters (70 R) after seeing phi_c (issue 18)"}])])


# ---------------------------------------------------------------- seed 002: the RKPM matrix

def run_rkpm_two_sphere(ctx):
    """bench_rkpm two at ctx.n grid nodes per edge against tools/two_sphere_reference.py (axisymmetric
    Q9 finite elements, body-fitted, the same ball, nu and alpha), run first."""
    import csv as _csv
    par = load_json(os.path.join(REPO, "benchmarks", "cpc_percolation", "two_sphere.json"))
    tier = par["tiers"][ctx.tier]
    b = tier["b_over_R"] * par["radius"]
    res = {}
    for a in tier["alpha_R_over_E"]:
        ref_csv = os.path.join(ctx.rundir, f"reference_a{a}.csv")
        ctx.command([sys.executable, os.path.join(REPO, "tools", "two_sphere_reference.py"), "--nu", str(par["poisson_ratio"]),
                     "--alpha-R-over-E", str(a), "--b-over-R", str(tier["b_over_R"]), "--levels",
                     str(tier["reference_levels"]), "--first-level", str(tier["reference_levels"] - 1), "--csv", ref_csv], f"reference_a{a}")
        ref_rows = list(_csv.DictReader(open(ref_csv)))
        ref = float(ref_rows[-1]["q"])
        env = {"RKPM_DOMAIN": "ball", "RKPM_BALL_RADIUS": str(b), "RKPM_ALPHA_R_OVER_E": str(a),
               "RKPM_DEPTH": str(tier["cut_cell_depth"]), "RKPM_SURFACE_SPACING": str(par["surface_spacing"]),
               "RKPM_NODES": str(ctx.n)}
        out_csv = ctx.command([ctx.runner.tool("benchmarks/cpc_percolation/bench_rkpm"), "two", str(par["poisson_ratio"]),
                               str(par["quadrature_order"]), str(par["cell_subdivision"])], f"rkpm_a{a}", extra_env=env)
        row = list(_csv.DictReader(open(out_csv)))[-1]
        res[f"alpha{a}"] = fig(row["distance_change_over_eps0_D"], ref, h_over_R=float(row["h_over_R"]),
                               nodes=int(row["nodes"]), unknowns=int(row["unknowns"]),
                               reference_change_last_level=float(ref_rows[-1]["change_from_previous_level"] or "nan"),
                               rkpm_seconds=float(row["assembly_s"]) + float(row["solve_s"]))
    return res


TWO_SRC = "seed 002 SM S4 (Fig. S6): two touching rigid spheres in an expanding matrix ball, RKPM matrix"
RKPM_TWO_SPHERE = Case(
    "seed002/rkpm_two_sphere", ["benchmarks/cpc_percolation/two_sphere.json"],
    {"fast": {"sizes": [15], "seeds": [1]}, "full": {"sizes": [26, 29, 33, 37], "seeds": [1]}},
    run_rkpm_two_sphere,
    [Figure("seed002/rkpm_two_sphere_alpha10", "alpha10", TWO_SRC + ", alpha R / E = 10 (the SI test's unit)",
            "tools/two_sphere_reference.py (axisymmetric body-fitted Q9 finite elements, level 5 (fast: 4), the same "
            "ball, nu, alpha; converged to 1e-6), run before the RKPM solve; band 2 % (issue 22)", 0.02, min_seeds=1),
     Figure("seed002/rkpm_two_sphere_alpha100", "alpha100", TWO_SRC + ", alpha R / E = 100 (the production unit)",
            "tools/two_sphere_reference.py as above; band 2 %", 0.02, min_seeds=1, tiers=["full"])])


def rkpm_rows(out, stage_name):
    import csv as _csv
    rows = list(_csv.DictReader(open(os.path.join(out, f"sweep_{stage_name}.csv"))))
    return [r for r in rows if r["status"] == "completed"]


def mean_std(xs):
    m = sum(xs) / len(xs)
    return m, (sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) ** 0.5 if len(xs) > 1 else float("nan")


def strain_histogram_figures(rows, edges):
    """Fig. 4's two numbers from the mean volume-weighted histogram of the max principal total
    strain at eps0 = 1 %: the centre of the fullest 0.01 % bin, and the weight below zero."""
    m = len(edges) - 1
    mean_h = [sum(float(r[f"ptc_strain_strain_total_hist_{k:02d}"]) for r in rows) / len(rows) for k in range(m)]
    k = max(range(m), key=lambda i: mean_h[i])
    negative = sum(float(r["ptc_strain_strain_total_negative_fraction"]) for r in rows) / len(rows)
    return 0.5 * (edges[k] + edges[k + 1]), negative


def run_switch_rkpm(config, stages, n_configs, with_strain):
    """One ledger seed = n_configs configurations (seeds (seed - 1) n + 1 .. seed n) per stage: the
    switching strain's mean and std over them; with_strain: Fig. 4's peak and negative weight."""
    def run(ctx):
        c = ctx.config(config)
        todo = stages if ctx.tier == "full" else dict(list(stages.items())[:1])
        c["stages"] = [st for st in c["stages"] if st["name"] in todo.values()]
        k = n_configs if ctx.tier == "full" else 1
        for st in c["stages"]:
            st["sweep"]["seeds"] = list(range((ctx.seed - 1) * k + 1, ctx.seed * k + 1))
            if ctx.tier == "fast":  # regression guard: one configuration in a 24 R box (seconds)
                st["generator"]["box_length"] = 24.0
        out = ctx.sparkdem(c)
        res = {}
        for key, name in todo.items():
            rows = rkpm_rows(out, name)
            eps = [float(r["ptc_strain_switching_strain"]) for r in rows]
            if not eps:
                continue
            m, sd = mean_std(eps)
            closing = [float(r["ptc_strain_opening_negative_fraction"]) for r in rows]
            lam = next(st for st in c["stages"] if st["name"] == name)["generator"]["aggregation_lambda"]
            res[key] = fig(m, SWITCH[lam == 0], std=sd, configurations=len(eps), closing_fraction=sum(closing) / len(closing),
                           opening_mean=sum(float(r["ptc_strain_opening_mean"]) for r in rows) / len(rows))
            if with_strain and lam != 70.0 and ctx.tier == "full":
                mod = next(st for st in c["stages"] if st["name"] == name)["modules"]["ptc_strain"]
                peak, neg = strain_histogram_figures(rows, mod["strain_histogram_edges"])
                res[key + "_peak"] = fig(peak, 0.0004, configurations=len(rows))
                res[key + "_negative"] = fig(neg, 0.13, configurations=len(rows))
        return res
    return run


RKPM_SRC = SWITCH_SRC + ", the paper's RKPM continuum matrix at its resolution (node spacing 3 R)"
RKPM_REF = "3.15 % (uniform) / 2.85 % (segregated) (paper, Fig. 5), band 10 % (VALIDATION.md); mean over 4 configurations"
SWITCH_RKPM = Case(
    "seed002/switch_rkpm", ["configs/cpc_ptc_rkpm.json"],
    {"fast": {"sizes": [0], "seeds": [1]}, "full": {"sizes": [0], "seeds": [1]}},
    # the first stage is the fast tier's (24 R box, one configuration: the segregated network spans it)
    run_switch_rkpm("configs/cpc_ptc_rkpm.json", {"segregated": "L70_lambda35_rkpm", "uniform": "L70_lambda0_rkpm",
                                                   "segregated_D": "L70_lambda70_rkpm"}, 4, True),
    [Figure("seed002/switch_strain_rkpm_uniform", "uniform", RKPM_SRC + ", uniform", RKPM_REF, 0.10, min_seeds=1,
            tiers=["full"]),
     Figure("seed002/switch_strain_rkpm_segregated", "segregated", RKPM_SRC + ", segregated (lambda = 35 R, the SM's reading)",
            RKPM_REF, 0.10, min_seeds=1),
     # No figure for lambda = 70 R (the main text's lambda D reading): cpc_fillers builds the same
     # configurations as for lambda = 35 R in this 70 R box (issue 60's rerun: equal in every
     # configuration), so its value would count one run twice; the run keeps it in res["segregated_D"].
     Figure("seed002/strain_peak_uniform", "uniform_peak", RKPM_SRC + ", uniform: Fig. 4's peak of the max principal strain "
            "at eps0 = 1 %", "0.03-0.05 % (paper's text on Fig. 4): 0.04 % +- 0.01 % (absolute)", 0.0001, min_seeds=1,
            absolute=True, tiers=["full"]),
     Figure("seed002/strain_negative_uniform", "uniform_negative", RKPM_SRC + ", uniform: Fig. 4's weight of negative "
            "strain at eps0 = 1 %", "about 16 % and 10 % for the two dispersions (paper's text): 0.13 +- 0.03 (absolute)",
            0.03, min_seeds=1, absolute=True, tiers=["full"]),
     Figure("seed002/strain_peak_segregated", "segregated_peak", RKPM_SRC + ", segregated: Fig. 4's peak",
            "0.04 % +- 0.01 % (absolute)", 0.0001, min_seeds=1, absolute=True, tiers=["full"]),
     Figure("seed002/strain_negative_segregated", "segregated_negative", RKPM_SRC + ", segregated: Fig. 4's negative weight",
            "0.13 +- 0.03 (absolute)", 0.03, min_seeds=1, absolute=True, tiers=["full"])])

VARIANT_TAGS = ("nu0.30", "nu0.40", "alpha10", "clamped", "rollers")
SWITCH_RKPM_VARIANTS = Case(
    "seed002/switch_rkpm_variants", ["configs/cpc_ptc_rkpm_variants.json"],
    {"full": {"sizes": [0], "seeds": [1]}},
    run_switch_rkpm("configs/cpc_ptc_rkpm_variants.json",
                    {f"{d}_{t}": f"L70_lambda{lam}_rkpm_{t}" for d, lam in (("uniform", 0), ("segregated", 35))
                     for t in VARIANT_TAGS}, 2, False),
    [Figure(f"seed002/switch_strain_rkpm_{d}_{t}", f"{d}_{t}", RKPM_SRC + f", {d}, variant {t} (one choice changed)",
            RKPM_REF.replace("4 configurations", "2 configurations"), 0.10, min_seeds=1, kind="study")
     for d in ("uniform", "segregated") for t in VARIANT_TAGS])

def run_switch_unit_box(ctx):
    """Issue 60 item 4: per dispersion the switching strain (mean over 4 configurations) with what the
    paper says beside it: Z(1 %) / Z(0), the first listed eps0 with Z <= 0.1 Z(0), the drop of the
    effective volume fraction phi_eff = phi / (1 + eps0 tr A) at eps0 = 3 % [points], Fig. 4's peak
    and negative weight."""
    c = ctx.config("configs/cpc_ptc_rkpm_unit_box.json")
    for st in c["stages"]:
        st["sweep"]["seeds"] = list(range((ctx.seed - 1) * 4 + 1, ctx.seed * 4 + 1))
    out = ctx.sparkdem(c)
    res = {}
    for st in c["stages"]:
        rows = rkpm_rows(out, st["name"])
        mod = st["modules"]["ptc_strain"]
        uniform = st["generator"]["aggregation_lambda"] == 0.0
        key = "uniform" if uniform else "segregated"
        m, sd = mean_std([float(r["ptc_strain_switching_strain"]) for r in rows])

        def z(e):
            col = "ptc_strain_coordination_" + f"{100 * e:.2f}".replace(".", "p") + "pct"
            return sum(float(r[col]) for r in rows) / len(rows)
        z0 = z(0.0)
        gone = next((e for e in mod["eps0_values"] if z(e) <= 0.1 * z0), None)
        phi = sum(float(r["packing.volume_fraction"]) for r in rows) / len(rows)
        tra = sum(float(r["ptc_strain_composite_volumetric_strain"]) for r in rows) / len(rows) / mod["opening_strain"]
        peak, neg = strain_histogram_figures(rows, mod["strain_histogram_edges"])
        res[key] = fig(m, SWITCH[uniform], std=sd, configurations=len(rows), z_ratio_at_1pct=z(0.01) / z0,
                       z_ratio_paper=">= 0.95 (modest change up to about 1 %)", z_below_10pct_at=gone,
                       phi_eff_drop_points_at_3pct=100.0 * (phi - phi / (1.0 + 0.03 * tra)), phi_eff_drop_paper=1.6,
                       fig4_peak=peak, fig4_peak_paper=0.0004, fig4_negative_weight=neg,
                       fig4_negative_paper=0.16 if uniform else 0.10)
    return res


UNIT_BOX_WHY = ("issue 60's audit: the SI test's unit box kept for production reproduces the switching strain (3.74 / "
                "3.58 % segregated, 3.78 % uniform on 1-2 configurations) - the reading was found after those figures had "
                "been seen")
SWITCH_RKPM_UNIT_BOX = Case(
    "seed002/switch_rkpm_unit_box", ["configs/cpc_ptc_rkpm_unit_box.json"],
    {"full": {"sizes": [0], "seeds": [1]}},
    run_switch_unit_box,
    [Figure(f"seed002/switch_strain_rkpm_unit_box_{d}", d, RKPM_SRC + f", {d}, the reading unit_box (alpha R / E = "
            "100 / 70, break gap 3.5 % of D, free expansion): the paper's numerics read in its SI test's unit box",
            RKPM_REF + "; beside it Z(1 %) / Z(0) (paper >= 0.95), phi_eff's drop at 3 % (paper about 1.6 points), Fig. 4's "
            "peak (0.04 %) and negative weight (16 / 10 %): expected misses", 0.10, min_seeds=1,
            tuned=[{"parameter": f"configs/cpc_ptc_rkpm_unit_box.json#{k}", "why": UNIT_BOX_WHY}
                   for k in ("bond_penalty", "break_gap_rel")])
     for d in ("uniform", "segregated")])

RKPM_TUNED_WHY = ("chosen by the selection rule of benchmarks/cpc_percolation/numerics_scan.py on Fig. 4, Fig. 7 and the "
                  "mean local strain (issue 39 item 2; rkpm_results.md section 8), before the switching strain was looked "
                  "at: a reading of numerics the paper does not give")
SWITCH_RKPM_TUNED = Case(
    "seed002/switch_rkpm_tuned", ["configs/cpc_ptc_rkpm_tuned.json"],
    {"full": {"sizes": [0], "seeds": [1]}},
    run_switch_rkpm("configs/cpc_ptc_rkpm_tuned.json", {"uniform": "L70_lambda0_rkpm_tuned",
                                                         "segregated": "L70_lambda35_rkpm_tuned"}, 4, False),
    [Figure(f"seed002/switch_strain_rkpm_tuned_{d}", d, RKPM_SRC + f", {d}, the numerics chosen on Figs. 4 and 7 "
            "(alpha R / E, beta h / E on every face, rho / h)", RKPM_REF, 0.10, min_seeds=1, kind="study",
            tuned=[{"parameter": f"configs/cpc_ptc_rkpm_tuned.json#{k}", "why": RKPM_TUNED_WHY}
                   for k in ("bond_penalty", "boundary", "boundary_penalty", "support_factor")])
     for d in ("uniform", "segregated")])


def hs_rigid_volumetric(phi, nu):
    """tr A per unit eps0 of a matrix with eigenstrain eps0 I holding rigid spheres at volume fraction
    phi: 3 K_m / K_HS (Levin's relation with the Hashin-Shtrikman bulk modulus, rigid inclusions:
    K_HS = K_m + phi (3 K_m + 4 G_m) / (3 (1 - phi))); E cancels."""
    k, g = 1.0 / (3.0 * (1.0 - 2.0 * nu)), 1.0 / (2.0 * (1.0 + nu))
    return 3.0 * k / (k + phi * (3.0 * k + 4.0 * g) / (3.0 * (1.0 - phi)))


def run_switch_rkpm_converged(ctx):
    """Per dispersion (the stages' aggregation lambda: 0 uniform, > 0 segregated) the switching
    strain and tr A at each node spacing; the finest spacing carries the figures."""
    c = ctx.config("configs/cpc_ptc_rkpm_converged.json")
    for st in c["stages"]:
        st["sweep"]["seeds"] = list(range((ctx.seed - 1) * 4 + 1, ctx.seed * 4 + 1))
    out = ctx.sparkdem(c)
    per = {}  # uniform -> {h: (switch mean/std, trA mean/std, phi, nu)}
    for st in c["stages"]:
        rows = rkpm_rows(out, st["name"])
        m = st["modules"]["ptc_strain"]
        eps = [float(r["ptc_strain_switching_strain"]) for r in rows]
        tra = [float(r["ptc_strain_composite_volumetric_strain"]) / m["opening_strain"] for r in rows]
        phi = sum(float(r["packing.volume_fraction"]) for r in rows) / len(rows)
        uniform = st["generator"].get("aggregation_lambda", 0.0) == 0.0
        per.setdefault(uniform, {})[m["node_spacing"]] = (mean_std(eps), mean_std(tra), phi, m["poisson_ratio"], len(rows))
    figs = {}
    for uniform, per_h in per.items():
        tag = "_uniform" if uniform else ""
        coarse_first = sorted(per_h, reverse=True)
        (m, sd), (ta, tsd), phi, nu, n = per_h[coarse_first[-1]]
        coarser = per_h[coarse_first[-2]][0][0]
        figs["switch" + tag] = fig(m, SWITCH[uniform], std=sd, configurations=n, last_refinement_change=m / coarser - 1.0,
                                   measured_composites=MEASURED_SWITCH,
                                   **{f"h{h:g}R": per_h[h][0][0] for h in coarse_first})
        figs["expansion" + tag] = fig(ta, hs_rigid_volumetric(phi, nu), std=tsd, configurations=n, phi=phi,
                                      **{f"trA_h{h:g}R": per_h[h][1][0] for h in coarse_first})
    return figs


# The paper's measured Ag / Cu composites switch at 0.4-0.6 % thermal strain (seed 002, Fig. 5's discussion).
MEASURED_SWITCH = [0.004, 0.006]
CONVERGED_SRC = ("seed 002, free expansion at alpha R / E = 10 (the SI test's unit; two-sphere test within 0.05 %), "
                 "segregated (lambda = 35 R), 24 R box, node spacing 1.5 R (3 and 2 R beside it)")
CONVERGED_UNI_SRC = CONVERGED_SRC.replace("segregated (lambda = 35 R)", "uniform (lambda = 0)")
SWITCH_RKPM_CONVERGED = Case(
    "seed002/switch_rkpm_converged", ["configs/cpc_ptc_rkpm_converged.json"],
    {"full": {"sizes": [0], "seeds": [1]}},
    run_switch_rkpm_converged,
    [Figure("seed002/switch_strain_rkpm_converged_segregated", "switch", CONVERGED_SRC + ": switching strain, the "
            "converged continuum (issue 39 item 3: last refinement within 10 %)",
            "2.85 % (paper, Fig. 5, segregated), band 10 % (VALIDATION.md); the paper's measured Ag / Cu composites "
            "switch at 0.4-0.6 % thermal strain", 0.10, min_seeds=1),
     Figure("seed002/composite_expansion_rkpm_converged", "expansion", CONVERGED_SRC + ": the fillers' affine "
            "volumetric strain tr A per unit eps0 (ptc_strain_composite_volumetric_strain)",
            "closed form: 3 K_m / K_HS, rigid spheres in the Hashin-Shtrikman bulk modulus (Levin's relation) at the "
            "packing's phi and nu = 0.35 (2.03 at phi = 25 %), fixed in the physics review before any run; band 5 % "
            "(set after the 2-configuration scan of numerics_scan_resolution_L24.csv had been seen)", 0.05, min_seeds=1),
     # Issue 60 item 3: the uniform dispersion beside it (references and bands as the segregated ones, fixed before the run).
     Figure("seed002/switch_strain_rkpm_converged_uniform", "switch_uniform", CONVERGED_UNI_SRC + ": switching strain, "
            "the converged continuum (last refinement within 10 %)",
            "3.15 % (paper, Fig. 5, uniform), band 10 % (VALIDATION.md); the paper's measured Ag / Cu composites "
            "switch at 0.4-0.6 % thermal strain", 0.10, min_seeds=1),
     Figure("seed002/composite_expansion_rkpm_converged_uniform", "expansion_uniform", CONVERGED_UNI_SRC + ": the "
            "fillers' affine volumetric strain tr A per unit eps0",
            "closed form: 3 K_m / K_HS at the packing's phi and nu = 0.35; band 5 % (as the segregated figure)", 0.05,
            min_seeds=1)])


# ---------------------------------------------------------------- closed forms

def run_thermal_stiff(ctx):
    c = ctx.config("configs/thermal_stiff.json")
    s = summary(ctx.sparkdem(c))
    return {k: fig(check(s, n)["value"], check(s, n)["reference"])
            for k, n in (("hot", "hottest_temperature"), ("mean", "mean_temperature_conserved"))}


THERMAL_STIFF = Case(
    "closed/thermal_stiff", ["configs/thermal_stiff.json"],
    {"fast": {"sizes": [0], "seeds": [1]}, "full": {"sizes": [0], "seeds": [1]}},
    run_thermal_stiff,
    [Figure("closed/thermal_stiff_hottest", "hot", "closed form: conduction in a chain with a 1e8 conductance contrast",
            "exact modal solution exp(-C^-1 L t) T0 (tests/support/thermal_network.hpp); band: the backward-Euler "
            "error bound of the implicit step 1000 x the explicit stable step", 0.014, min_seeds=1),
     Figure("closed/thermal_stiff_heat_conserved", "mean", "closed form: conduction conserves heat",
            "(C_L (500 + 3 x 300) + C_t 300) / (4 C_L + C_t) - 300 K", 1e-9, min_seeds=1)])


CASES = [PACKING, CYLINDER, CYLINDER_GAP002, CYLINDER_FIT, JOULE_ROD, NOTCH, PLATE, BEAM, BEAM_CONTACT, TORSION, TORSION_CONTACT, NIAL, NIAL_AFFINE, NIAL_SMALL, TABLE1_DENSIFICATION, TABLE1_DENSIFICATION_QS, CPC, CPC_POOLED, CPC_T_GRID, CPC_SEG, CPC_SEG_R, SWITCH_BONDED, RKPM_TWO_SPHERE, SWITCH_RKPM, SWITCH_RKPM_VARIANTS, SWITCH_RKPM_UNIT_BOX,
         SWITCH_RKPM_TUNED, SWITCH_RKPM_CONVERGED,
         THERMAL_STIFF]

# The headline figures (README's validation table: tools/validate.py's `headline` table): per case its
# main figure at the paper's size.
HEADLINE = [("seed000/nial_kappa_0.216", 17876), ("seed000/nial_kappa_0.050", 17876),
            ("seed000/table1_porosity_sample3", 300), ("seed001/cylinder_resistance", 20000),
            ("seed001/joule_rod_rise", 5000), ("seed001/notch_resistance", 20664), ("seed001/plate_P1", 20000),
            ("seed001/beam_E_M", 10000), ("seed001/torsion_contact_onset_from_R", 5000), ("seed002/phi_c_uniform", 0),
            ("seed002/t_exponent", 0), ("seed002/switch_strain_rkpm_uniform", 0),
            ("closed/thermal_stiff_hottest", 0)]
