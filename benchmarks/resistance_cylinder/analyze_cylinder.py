#!/usr/bin/env python3
"""Diagnostics of seed 001's cylinder resistance runs (section 3.1), beside the validation ledger.

    analyze_cylinder.py tabulate WORKDIR OUTDIR     -> OUTDIR/results.csv, results.md (+ variants.csv)
    analyze_cylinder.py variant-scenario RUNDIR     -> prints a scenario re-solving RUNDIR's packing

HDF5 frames are read with h5py (Debian's python3-h5py).

The runs come from tools/validate.py (ledger case seed001/cylinder; the validation figure, R_DEM
against R_th, is the ledger's seed001/cylinder_resistance, benchmarks/validation/ledger.md):

    /usr/bin/python3 -m tools.validate run --tier full --case seed001/cylinder [--sizes N ...] [--seeds S ...]

writes one directory per run, <workdir>/<tier>/seed001_cylinder/N<n>_seed<s>/ (<workdir> defaults
to build/validation), holding scenario.json (configs/resistance_cylinder.json with only the fill's
`particles` and the top-level `seed` changed), out/ (sparkdem's output) and scenario.meta.json
(exit code, wall and CPU seconds, load average at the start). WORKDIR is
<workdir>/<tier>/seed001_cylinder. The columns process_cpu_s and load_average* come from the
bench_meta.txt of the runs made before validate.py; they stay empty for validate.py's directories
(their times are in scenario.meta.json and in the ledger).

Variants (diagnostics, never the result): each finished packing re-solved from its final_state.h5
(no new fill) with one setting of the electrical stage changed (VARIANTS below):

    analyze_cylinder.py variant-scenario RUNDIR > RUNDIR/variants.json
    build/sparkdem run RUNDIR/variants.json -o RUNDIR/variants --threads 1 --quiet

then `tabulate` reads RUNDIR/variants/sweep_*.csv into variants.csv (the committed
benchmarks/resistance_cylinder/variants.csv is such a table). OUTDIR also receives results.csv and
results.md: give a scratch directory and copy variants.csv when refreshing the committed one.

Definitions (SI units throughout):
  R_dem     final `electrical_resistance` of the electrical stage (summary.json), dV / I [Ohm]
  r_mean    mean particle radius of the final frame [m]
  R_th      rho_e (l_d - 2 r_mean) / (pi r_d^2), seed 001 Eq. 17 [Ohm]
  error_pct 100 (R_dem - R_th) / R_th (negative: the packing conducts better than the continuum)
Diagnostics (never a replacement of the paper's definition):
  l_centroid  distance of the electrode sets' centroid planes (mean z of the high set minus mean
              z of the low set) [m]; error_lc_pct uses it in place of l_d - 2 r_mean
  r_bound     radius of the packing's bounding cylinder, max(sqrt(x^2 + y^2) + r) [m];
              error_abound_pct uses pi r_bound^2 in place of pi r_d^2
  n_network   mean number of conducting branches per particle (what alpha(n) sees)
  f2_fraction fraction of particles with eccentricity e >= 0.4 (S halved, seed 001 Eq. 3)
"""
import csv
import glob
import json
import math
import os
import statistics
import subprocess
import sys

# GranOO (seed 001 Table III): error magnitudes in %, three generations per N. The PDF lost the
# signs; all three at N = 20000 carry the same sign (their mean, 2.9 %, is quoted).
GRANOO = {1000: (6.08, 10.51, 9.19), 2000: (12.28, 12.57, 15.56), 5000: (4.11, 5.80, 4.04),
          10000: (4.41, 3.60, 3.31), 20000: (2.60, 2.92, 3.04)}

# Diagnostic variants of the electrical model re-solved on each finished packing: (label, JSON
# pointer relative to the stage, values). Each changes one thing; none is the result.
VARIANTS = [
    ("touch_tolerance", "/modules/electrical_network/touch_tolerance", [0.0, 1e-7, 1e-5]),
    ("alpha_constant", "/modules/electrical_network/alpha_constant", [4.0]),
]


def h5_dataset(path, name):
    """Values of dataset `name` in HDF5 file `path`, flattened, as floats (full precision; h5py)."""
    import h5py
    with h5py.File(path, "r") as f:
        return [float(x) for x in f[name][()].ravel()]


def last_frame(outdir):
    frames = sorted(glob.glob(os.path.join(outdir, "frames", "frame_*.h5")))
    if not frames:
        raise FileNotFoundError(f"{outdir}: no frames")
    return frames[-1]


def electrical_stage(summary):
    for st in summary.get("stages", []):
        if "electrical_resistance" in st.get("final", {}):
            return st
    return None


def fill_stage(summary):
    for st in summary.get("stages", []):
        if st.get("type") in ("fill", "relax"):  # the packing stage (relax since issue 19)
            return st
    return None


def scenario_geometry(scenario):
    fill = next(st for st in scenario["stages"] if st.get("type") in ("fill", "relax"))
    g = fill["generator"]
    if g.get("shape") != "cylinder":
        raise ValueError("the fill generator is not a cylinder")
    el = None
    for st in scenario["stages"]:
        m = st.get("modules", {}).get("electrical_network")
        if m is not None:
            el = m
    if el is None or el.get("model") != "transmission_surface":
        raise ValueError("no transmission_surface electrical_network stage")
    rho_e = el["resistivity"] if el.get("resistivity", 0.0) > 0.0 else 1.0 / el["conductivity"]
    return {"r_d": g["radius"], "l_d": g["length"], "rho_e": rho_e, "high": el["high"], "low": el["low"],
            "particles": g["particles"], "seed": scenario.get("seed")}


def frame_geometry(frame, high, low, rho_e=None):
    """r_mean, electrode centroid planes, bounding radius, network coordination and eccentricity."""
    pos = h5_dataset(frame, "/particles/position")
    rad = h5_dataset(frame, "/particles/radius")
    ids = [int(round(x)) for x in h5_dataset(frame, "/particles/id")]
    hi = h5_dataset(frame, f"/particles/set_{high}")
    lo = h5_dataset(frame, f"/particles/set_{low}")
    n = len(rad)
    xyz = [(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]) for i in range(n)]
    z_hi = [xyz[i][2] for i in range(n) if hi[i] > 0.5]
    z_lo = [xyz[i][2] for i in range(n) if lo[i] > 0.5]
    out = {
        "r_mean_m": sum(rad) / n,
        "n_high": len(z_hi), "n_low": len(z_lo),
        "l_centroid_m": sum(z_hi) / len(z_hi) - sum(z_lo) / len(z_lo),
        "r_bound_m": max(math.hypot(p[0], p[1]) + r for p, r in zip(xyz, rad)),
    }
    # Conducting branches of the solved network (end ids; a wall end is negative).
    try:
        pairs = h5_dataset(frame, "/networks/electrical/pairs")
        cond = h5_dataset(frame, "/networks/electrical/conductance")
    except subprocess.CalledProcessError:
        return out
    index = {pid: k for k, pid in enumerate(ids)}
    count = [0] * n
    acc = [[0.0, 0.0, 0.0] for _ in range(n)]
    for b in range(len(cond)):
        a_id, b_id = int(round(pairs[2 * b])), int(round(pairs[2 * b + 1]))
        if not (cond[b] > 0.0) or a_id < 0 or b_id < 0:
            continue
        ia, ib = index[a_id], index[b_id]
        for i, j in ((ia, ib), (ib, ia)):
            count[i] += 1
            for c in range(3):
                acc[i][c] += xyz[j][c]
    ecc = []
    for i in range(n):
        if count[i]:
            d = [acc[i][c] / count[i] - xyz[i][c] for c in range(3)]
            ecc.append(math.sqrt(sum(x * x for x in d)) / rad[i])
    out["n_network"] = sum(count) / n
    out["isolated"] = sum(1 for c in count if c == 0)
    out["f2_fraction"] = sum(1 for e in ecc if e >= 0.4) / n
    if rho_e is None:
        return out
    # Decomposition of the transmission-surface model on this network (Python re-solve of the
    # branches in the frame): S_i = alpha(n_i) r_i^2 / f(e_i) recomputed and checked against the
    # frame's conductances, then alpha and f replaced one at a time.
    e_full = [0.0] * n
    for i in range(n):
        if count[i]:
            d = [acc[i][c] / count[i] - xyz[i][c] for c in range(3)]
            e_full[i] = math.sqrt(sum(x * x for x in d)) / rad[i]
    f = [2.0 if e >= 0.4 - 1e-12 else 1.0 for e in e_full]
    ea, eb, lij, g0 = [], [], [], []
    for b in range(len(cond)):
        a_id, b_id = int(round(pairs[2 * b])), int(round(pairs[2 * b + 1]))
        if not (cond[b] > 0.0) or a_id < 0 or b_id < 0:
            continue
        ia, ib = index[a_id], index[b_id]
        ea.append(ia)
        eb.append(ib)
        lij.append(math.dist(xyz[ia], xyz[ib]))
        g0.append(cond[b])

    def conductances(alpha_of, f_of):
        S = [alpha_of(count[i]) * rad[i] ** 2 / f_of(i) for i in range(n)]
        return [math.sqrt(S[a] * S[b]) / (rho_e * l) for a, b, l in zip(ea, eb, lij)]

    g_model = conductances(alpha_platonic, lambda i: f[i])
    out["g_check_max_rel"] = max(abs(x / y - 1.0) for x, y in zip(g_model, g0)) if g0 else math.nan
    high = [i for i in range(n) if hi[i] > 0.5]
    low = [i for i in range(n) if lo[i] > 0.5]
    solve = lambda g: network_resistance(n, ea, eb, g, high, low)
    out["R_py_model"] = solve(g0)
    out["R_py_f1"] = solve(conductances(alpha_platonic, lambda i: 1.0))
    out["R_py_alpha4"] = solve(conductances(lambda k: 4.0, lambda i: f[i]))
    out["R_py_alpha4_f1"] = solve(conductances(lambda k: 4.0, lambda i: 1.0))
    return out


def meta(rundir):
    m = {}
    p = os.path.join(rundir, "bench_meta.txt")
    if os.path.exists(p):
        for line in open(p):
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "time_wall_user_sys":
                m["process_wall_s"], m["user_s"], m["sys_s"] = map(float, parts[1:4])
            elif parts[0] in ("load_start", "load_end"):
                m[parts[0]] = parts[1]
            elif parts[0] == "exit":
                m["exit"] = int(parts[1])
    return m


def err(r, ref):
    return 100.0 * (r - ref) / ref


def alpha_platonic(n):
    """alpha(n) of physics/electrical/conductance_kernels.cpp (TransmissionSurfaceModel::platonic):
    face area / inradius^2 of the regular polyhedra with n = 4, 6, 8, 12, 20 faces, linear in
    between, linear extrapolation outside, n clamped to [3, 20]."""
    s3, s5 = math.sqrt(3.0), math.sqrt(5.0)
    xs = [4.0, 6.0, 8.0, 12.0, 20.0]
    ys = [6.0 * s3, 4.0, 1.5 * s3, math.sqrt(25.0 + 10.0 * s5) / 4.0 * 400.0 / (250.0 + 110.0 * s5),
          12.0 * s3 / ((3.0 + s5) ** 2)]
    x = min(max(float(n), 3.0), 20.0)
    k = 0 if x < xs[1] else len(xs) - 2 if x >= xs[-2] else max(i for i in range(len(xs) - 1) if xs[i] <= x)
    return ys[k] + (ys[k + 1] - ys[k]) * (x - xs[k]) / (xs[k + 1] - xs[k])


def network_resistance(n, ea, eb, g, high, low, tol=1e-11):
    """R = 1 V / I of the resistor network (edges ea-eb, conductances g [S]) with the nodes in
    `high` at 1 V and those in `low` at 0 V: Jacobi-preconditioned CG on the free nodes."""
    fixed = [0] * n
    for i in high:
        fixed[i] = 1
    for i in low:
        fixed[i] = 2
    diag = [0.0] * n
    rhs = [0.0] * n
    ff = []
    for a, b, c in zip(ea, eb, g):
        diag[a] += c
        diag[b] += c
        if not fixed[a] and not fixed[b]:
            ff.append((a, b, c))
        elif not fixed[a] and fixed[b] == 1:
            rhs[a] += c
        elif not fixed[b] and fixed[a] == 1:
            rhs[b] += c
    free = [i for i in range(n) if not fixed[i] and diag[i] > 0.0]
    inv = [1.0 / d if d > 0.0 else 0.0 for d in diag]

    def matvec(x):
        y = [0.0] * n
        for i in free:
            y[i] = diag[i] * x[i]
        for a, b, c in ff:
            y[a] -= c * x[b]
            y[b] -= c * x[a]
        return y

    x = [0.0] * n
    r = rhs[:]
    z = [r[i] * inv[i] for i in range(n)]
    pvec = z[:]
    rz = sum(r[i] * z[i] for i in free)
    norm0 = math.sqrt(sum(r[i] * r[i] for i in free)) or 1.0
    for _ in range(20 * n + 100):
        q = matvec(pvec)
        pq = sum(pvec[i] * q[i] for i in free)
        if pq <= 0.0:
            break
        a = rz / pq
        for i in free:
            x[i] += a * pvec[i]
            r[i] -= a * q[i]
        if math.sqrt(sum(r[i] * r[i] for i in free)) < tol * norm0:
            break
        for i in free:
            z[i] = r[i] * inv[i]
        rz_new = sum(r[i] * z[i] for i in free)
        beta = rz_new / rz
        rz = rz_new
        for i in free:
            pvec[i] = z[i] + beta * pvec[i]
    current = 0.0
    for a, b, c in zip(ea, eb, g):
        va = 1.0 if fixed[a] == 1 else 0.0 if fixed[a] == 2 else x[a]
        vb = 1.0 if fixed[b] == 1 else 0.0 if fixed[b] == 2 else x[b]
        if fixed[a] == 1 and fixed[b] != 1:
            current += c * (va - vb)
        elif fixed[b] == 1 and fixed[a] != 1:
            current += c * (vb - va)
    return 1.0 / current if current > 0.0 else math.inf


def analyse_run(rundir):
    scenario = json.load(open(os.path.join(rundir, "scenario.json")))
    geo = scenario_geometry(scenario)
    row = {"N": geo["particles"], "seed": geo["seed"], "status": "missing"}
    m = meta(rundir)
    sp = os.path.join(rundir, "out", "summary.json")
    if not os.path.exists(sp):
        return row, None
    s = json.load(open(sp))
    row["status"] = s.get("status", "?")
    est, fst = electrical_stage(s), fill_stage(s)
    if row["status"] != "completed" or est is None or fst is None:
        return row, None
    fr = frame_geometry(last_frame(os.path.join(rundir, "out")), geo["high"], geo["low"], geo["rho_e"])
    rho, r_d, l_d = geo["rho_e"], geo["r_d"], geo["l_d"]
    area = math.pi * r_d ** 2
    r_dem = est["final"]["electrical_resistance"]
    r_th = rho * (l_d - 2.0 * fr["r_mean_m"]) / area
    r_th_lc = rho * fr["l_centroid_m"] / area
    r_th_ab = rho * (l_d - 2.0 * fr["r_mean_m"]) / (math.pi * fr["r_bound_m"] ** 2)
    r_th_both = rho * fr["l_centroid_m"] / (math.pi * fr["r_bound_m"] ** 2)
    p = fst.get("packing", {})
    row.update({
        "particles": est["particles"],
        "r_mean_m": fr["r_mean_m"],
        "R_dem_ohm": r_dem,
        "R_th_ohm": r_th,
        "error_pct": err(r_dem, r_th),
        "fill_wall_s": fst["wall_time_s"],
        "solve_wall_s": est["wall_time_s"],
        "electrical_solve_s": est["final"].get("electrical_solve_time"),
        "total_wall_s": s["wall_time_s"],
        "process_cpu_s": m["user_s"] + m["sys_s"] if "user_s" in m else None,
        "load_average": m.get("load_start"),
        "load_average_end": m.get("load_end"),
        "l_centroid_m": fr["l_centroid_m"],
        "error_lc_pct": err(r_dem, r_th_lc),
        "r_bound_m": fr["r_bound_m"],
        "error_abound_pct": err(r_dem, r_th_ab),
        "error_lc_abound_pct": err(r_dem, r_th_both),
        "packing_density": p.get("packing_density"),
        "packing_density_interior": p.get("packing_density_interior"),
        "max_overlap_ratio": p.get("max_overlap_ratio"),
        "growth_scale": p.get("growth_scale"),
        "fill_until_reached": fst.get("until_reached"),
        "fill_steps": fst.get("steps"),
        "final_ke_per_mass": fst.get("final", {}).get("kinetic_energy_per_mass"),
        "coordination_contacts": p.get("coordination_mean"),
        "n_network": fr.get("n_network"),
        "f2_fraction": fr.get("f2_fraction"),
        "floating_nodes": est["final"].get("electrical_floating_nodes"),
        "g_check_max_rel": fr.get("g_check_max_rel"),
        "error_py_model_pct": err(fr["R_py_model"], r_th) if "R_py_model" in fr else None,
        "error_f1_pct": err(fr["R_py_f1"], r_th) if "R_py_f1" in fr else None,
        "error_alpha4_pct": err(fr["R_py_alpha4"], r_th) if "R_py_alpha4" in fr else None,
        "error_alpha4_f1_pct": err(fr["R_py_alpha4_f1"], r_th) if "R_py_alpha4_f1" in fr else None,
        "electrode_high": fr["n_high"],
        "electrode_low": fr["n_low"],
    })
    # Diagnostic variants on the same packing (RUNDIR/variants: variant-scenario, see the docstring).
    variants = []
    for label, _, values in VARIANTS:
        table = os.path.join(rundir, "variants", f"sweep_{label}.csv")
        if not os.path.exists(table):
            continue
        for vr in csv.DictReader(open(table)):
            if vr.get("status") != "completed":
                continue
            rv = float(vr["electrical_resistance"])
            variants.append({"N": row["N"], "seed": row["seed"], "variant": label, "value": vr.get("value"),
                             "R_ohm": rv, "error_pct": err(rv, r_th), "change_vs_base_pct": err(rv, r_dem)})
    return row, variants


def variant_scenario(rundir):
    """A scenario that re-solves RUNDIR's final packing once per VARIANTS value (sweeps)."""
    sc = json.load(open(os.path.join(rundir, "scenario.json")))
    estage = next(st for st in sc["stages"] if "electrical_network" in st.get("modules", {}))
    snap = os.path.abspath(os.path.join(rundir, "out", "final_state.h5"))
    stages = []
    for label, pointer, values in VARIANTS:
        st = {k: v for k, v in estage.items() if k not in ("name", "output", "snapshots", "sweep")}
        base = st["modules"]["electrical_network"].get(pointer.rsplit("/", 1)[1])
        if base is not None and base not in values:  # the scenario's own value: must reproduce R_dem
            values = sorted(values + [base])
        st.update({"name": label, "type": "dynamics", "from_snapshot": snap, "stop": {"steps": 0},
                   "sweep": {"parameter": pointer, "values": values,
                             "collect": ["electrical_resistance", "electrical_floating_nodes"]}})
        stages.append(st)
    out = {k: v for k, v in sc.items() if k != "stages"}
    out["name"] = sc.get("name", "scenario") + "_variants"
    out["stages"] = stages
    json.dump(out, sys.stdout, indent=1)


def fmt(v, spec):
    if v is None or v == "":
        return ""
    if isinstance(v, float) and not math.isfinite(v):
        return "nan"
    return format(v, spec)


def mean_sd(xs):
    xs = [x for x in xs if x is not None]
    if not xs:
        return None, None
    return statistics.fmean(xs), (statistics.stdev(xs) if len(xs) > 1 else None)


def pm(xs, spec=".2f"):
    m, sd = mean_sd(xs)
    if m is None:
        return "-"
    return f"{m:{spec}}" + (f" ± {sd:{spec}}" if sd is not None else " (one run)")


def tabulate(workdir, outdir):
    rows, variants = [], []
    for d in sorted(glob.glob(os.path.join(workdir, "N*_seed*"))):
        if not os.path.exists(os.path.join(d, "scenario.json")):
            continue
        r, v = analyse_run(d)
        rows.append(r)
        variants += v or []
    rows.sort(key=lambda r: (r["N"], r["seed"]))
    cols = ["N", "seed", "particles", "r_mean_m", "R_dem_ohm", "R_th_ohm", "error_pct", "fill_wall_s",
            "solve_wall_s", "total_wall_s", "load_average", "status", "electrical_solve_s", "process_cpu_s",
            "load_average_end", "l_centroid_m", "error_lc_pct", "r_bound_m", "error_abound_pct",
            "error_lc_abound_pct", "packing_density", "packing_density_interior", "max_overlap_ratio",
            "growth_scale", "fill_until_reached", "fill_steps", "final_ke_per_mass", "coordination_contacts",
            "n_network", "f2_fraction", "floating_nodes", "electrode_high", "electrode_low", "g_check_max_rel",
            "error_py_model_pct", "error_f1_pct", "error_alpha4_pct", "error_alpha4_f1_pct"]
    spec = {"r_mean_m": ".6e", "R_dem_ohm": ".6e", "R_th_ohm": ".6e", "error_pct": ".3f", "fill_wall_s": ".1f",
            "solve_wall_s": ".4f", "total_wall_s": ".1f", "electrical_solve_s": ".4f", "process_cpu_s": ".1f",
            "l_centroid_m": ".6e", "error_lc_pct": ".3f", "r_bound_m": ".6e", "error_abound_pct": ".3f",
            "error_lc_abound_pct": ".3f", "packing_density": ".5f", "packing_density_interior": ".5f",
            "max_overlap_ratio": ".5f", "growth_scale": ".5f", "final_ke_per_mass": ".3e",
            "coordination_contacts": ".4f", "n_network": ".4f", "f2_fraction": ".4f", "floating_nodes": ".0f",
            "g_check_max_rel": ".2e", "error_py_model_pct": ".3f", "error_f1_pct": ".3f", "error_alpha4_pct": ".3f",
            "error_alpha4_f1_pct": ".3f"}
    os.makedirs(outdir, exist_ok=True)
    tmp = os.path.join(outdir, "results.csv.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([fmt(r.get(c), spec[c]) if c in spec else ("" if r.get(c) is None else r.get(c)) for c in cols])
    os.replace(tmp, os.path.join(outdir, "results.csv"))
    if variants:
        tmp = os.path.join(outdir, "variants.csv.tmp")
        vcols = ["N", "seed", "variant", "value", "R_ohm", "error_pct", "change_vs_base_pct"]
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=vcols)
            w.writeheader()
            for v in sorted(variants, key=lambda v: (v["N"], v["seed"], v["variant"], float(v["value"]))):
                w.writerow({k: (fmt(v[k], ".6e") if k == "R_ohm" else fmt(v[k], ".3f") if k.endswith("pct") else v[k])
                            for k in vcols})
        os.replace(tmp, os.path.join(outdir, "variants.csv"))

    ok = [r for r in rows if r["status"] == "completed" and "error_pct" in r]
    sizes = sorted({r["N"] for r in ok})
    md = ["# Cylinder resistance (seed 001, section 3.1): sparkdem against R_th and GranOO", "",
          "Generated by `analyze_cylinder.py tabulate` from the run directories given; every number below is",
          "computed from `results.csv`" + (" and `variants.csv`" if variants else "") + ". error = 100 (R_DEM - R_th) / R_th with",
          "R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2); negative means R_DEM < R_th. Mean ± sample standard",
          "deviation over the seeds. GranOO's errors are magnitudes (the paper's signs were lost).", "",
          "| N | runs | r_mean [µm] | error [%] | min / max [%] | GranOO \\|error\\| [%] (gen 1/2/3; mean) | fill wall [s] | fill CPU [s] | solve [ms] |",
          "|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        rs = [r for r in ok if r["N"] == n]
        e = [r["error_pct"] for r in rs]
        g = GRANOO.get(n)
        gtxt = " / ".join(f"{x:.2f}" for x in g) + f"; {statistics.fmean(g):.2f}" if g else "-"
        cpu = [r["process_cpu_s"] for r in rs]
        md.append(f"| {n} | {len(rs)} | {pm([r['r_mean_m'] * 1e6 for r in rs], '.1f')} | {pm(e)} | "
                  f"{min(e):.2f} / {max(e):.2f} | {gtxt} | {pm([r['fill_wall_s'] for r in rs], '.0f')} | "
                  f"{pm(cpu, '.0f')} | {pm([r['solve_wall_s'] * 1e3 for r in rs], '.1f')} |")
    md += ["", "Fill CPU is the process's user + system time (the whole run; the fill is nearly all of it): on a",
           "shared machine it is the steadier figure, wall times depend on the load (see `load_average` in the CSV).",
           "solve = wall time of the electrical stage (graph, conductances, direct solve, frame output).", "",
           "## Diagnostics: the reference's length and area, and the packing", "",
           "Same runs, R_th recomputed with one definition changed (diagnostic columns; the result above keeps",
           "the paper's definition): l_c = distance of the electrode sets' centroid planes instead of l_d - 2 r_mean;",
           "A_b = pi r_b^2 with r_b the bounding cylinder of the packing instead of pi r_d^2.", "",
           "| N | error [%] | error, l_c [%] | (l_d - 2 r_mean - l_c) / l_c [%] | error, A_b [%] | error, l_c and A_b [%] | density | interior density | contact coordination | network n | e ≥ 0.4 fraction |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        rs = [r for r in ok if r["N"] == n]
        # (l_d - 2 r_mean) / l_c - 1 follows from the two errors: (1 + e_lc) / (1 + e) - 1
        dl = [100.0 * ((1.0 + r["error_lc_pct"] / 100.0) / (1.0 + r["error_pct"] / 100.0) - 1.0) for r in rs]
        md.append(f"| {n} | {pm([r['error_pct'] for r in rs])} | {pm([r['error_lc_pct'] for r in rs])} | "
                  f"{pm(dl)} | {pm([r['error_abound_pct'] for r in rs])} | {pm([r['error_lc_abound_pct'] for r in rs])} | "
                  f"{pm([r['packing_density'] for r in rs], '.4f')} | {pm([r['packing_density_interior'] for r in rs], '.4f')} | "
                  f"{pm([r['coordination_contacts'] for r in rs])} | {pm([r['n_network'] for r in rs])} | "
                  f"{pm([r['f2_fraction'] for r in rs], '.3f')} |")
    md += ["", "## Diagnostics: the two factors of the transmission surface S_i = alpha(n_i) r_i^2 / f(e_i)", "",
           "The branches of each run's final frame are re-solved in Python (Jacobi CG): first as they are (must",
           "reproduce R_DEM; `g_check_max_rel` in the CSV is the largest relative difference between the",
           "recomputed and the frame's branch conductances), then with f = 1 for every particle, with alpha = 4",
           "(the cubic-lattice value) for every particle, and with both. Variants, not the result.", "",
           "| N | error [%] | re-solved [%] | f = 1 [%] | alpha = 4 [%] | alpha = 4, f = 1 [%] |",
           "|---|---|---|---|---|---|"]
    for n in sizes:
        rs = [r for r in ok if r["N"] == n and r.get("error_py_model_pct") is not None]
        if rs:
            md.append(f"| {n} | {pm([r['error_pct'] for r in rs])} | {pm([r['error_py_model_pct'] for r in rs])} | "
                      f"{pm([r['error_f1_pct'] for r in rs])} | {pm([r['error_alpha4_pct'] for r in rs])} | "
                      f"{pm([r['error_alpha4_f1_pct'] for r in rs])} |")
    if variants:
        md += ["", "## Diagnostic variants of the electrical model (same packings, re-solved; not the result)", "",
               "Each row changes one setting of the electrical stage and re-solves the final packing of every run",
               "(`analyze_cylinder.py variant-scenario`). error against the same R_th; change = 100 (R_variant - R_DEM) / R_DEM.", "",
               "| N | variant | value | runs | error [%] | change vs scenario [%] |", "|---|---|---|---|---|---|"]
        keys = sorted({(v["N"], v["variant"], float(v["value"])) for v in variants})
        for n, label, value in keys:
            vs = [v for v in variants if v["N"] == n and v["variant"] == label and float(v["value"]) == value]
            md.append(f"| {n} | {label} | {value:g} | {len(vs)} | {pm([v['error_pct'] for v in vs])} | "
                      f"{pm([v['change_vs_base_pct'] for v in vs])} |")
    bad = [r for r in rows if r["status"] != "completed"]
    if bad:
        md += ["", "Runs without a result: " + ", ".join(f"N={r['N']} seed={r['seed']} ({r['status']})" for r in bad)]
    with open(os.path.join(outdir, "results.md.tmp"), "w") as f:
        f.write("\n".join(md) + "\n")
    os.replace(os.path.join(outdir, "results.md.tmp"), os.path.join(outdir, "results.md"))
    for line in md[7:9 + len(sizes)]:
        print(line)
    print(f"wrote {os.path.join(outdir, 'results.csv')} and results.md ({len(ok)} of {len(rows)} runs completed)")


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "tabulate":
        tabulate(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 3 and sys.argv[1] == "variant-scenario":
        variant_scenario(sys.argv[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
