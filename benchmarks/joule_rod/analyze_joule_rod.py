#!/usr/bin/env python3
"""Scenarios and tables of the Joule-heated uniform rod (seed 001 section 3.3), beside the ledger.

    analyze_joule_rod.py run-name CONFIG N SEED MAXIT MAXOV   -> prints a run directory name
    analyze_joule_rod.py scenario CONFIG N SEED MAXIT MAXOV   -> prints the scenario of one run
    analyze_joule_rod.py tabulate WORKDIR OUTDIR              -> OUTDIR/results.csv, results.md

(SEED, MAXIT, MAXOV may be "" for the config's own values.) Python standard library only.

The runs come from tools/validate.py (ledger case seed001/joule_rod; the validation figure, the
mean rise against the analytic one, is the ledger's seed001/joule_rod_rise, and the capacity
variants are its side figures: benchmarks/validation/ledger.md). validate.py builds each run's
scenario with make_scenario() below (the config's relax stop settings) and writes one directory
per run, <workdir>/<tier>/seed001_joule_rod/N<n>_seed<s>/ (<workdir> defaults to
build/validation), holding scenario.json, out/ (sparkdem's output) and scenario.meta.json (exit
code, wall and CPU seconds, load average at the start). `tabulate` reads such a WORKDIR
(<workdir>/<tier>/seed001_joule_rod) for the per-stage diagnostics (bookkeeping dT / dT_bk,
capacity ratios, packing); its process_* and load_* columns come from the bench_meta.txt of the
runs made before validate.py and stay empty for validate.py's directories. OUTDIR: a scratch
directory (the committed results.csv / results.md were superseded by the ledger and removed).

A packing-stop study (relax max_iterations / max_overlap changed) is not a ledger case: write its
scenarios with `scenario CONFIG N SEED MAXIT MAXOV > DIR/<run-name>/scenario.json`, run
`sparkdem run DIR/<run-name>/scenario.json -o DIR/<run-name>/out --threads 1`, then
`tabulate DIR OUTDIR` (run-name gives N<n>_seed<s>_it<K>_ov<X>, which tabulate's N*_seed* matches).

The scenario of a run is CONFIG with: the relax generator's `particles` = N (and, when given, its
`max_iterations` / `max_overlap`, and the top-level `seed`); the check's reference = the analytic
rise for that N; and two more frozen stages after the config's joule stage (capacity "domain"):
`joule_sphere` and `joule_volume_fraction`, identical but for `capacity`. Every joule stage starts
from the packing of the relax stage (frozen mechanics) and from initial_temperature.

Definitions (SI units):
  r_eq1     (0.63 V_g / (4/3 pi N))^(1/3), seed 001 Eq. 1, V_g = pi r_d^2 l_d         [m]
  R_th      rho_e (l_d - 2 r_eq1) / (pi r_d^2)  (cohesive-joule-torsion.md 7.1)          [Ohm]
  dT_ref    dV^2 t / (R_th rho c V_g)  (7.3; the reference, fixed before the run)       [K]
  R_dem     final electrical_resistance of the stage                                     [Ohm]
  dT        final heat_temperature_mean - T0 (capacity-weighted mean rise)               [K]
  dT_bk     dV^2 t / (R_dem rho c V_g): the analytic formula with the DEM's own resistance;
            dT / dT_bk - 1 isolates the heating bookkeeping (capacities, power split, time
            integration) from the resistance error; it is 0 to round-off for capacity "domain"
            and (V_g / sum C_i/(rho c)) - 1 for the others
  cap_ratio heat_capacity_ratio = sum V_i / f_v,i over V_g (the GranOO capacity against the rod's)
"""
import csv
import glob
import json
import math
import os
import re
import statistics
import sys

T_CAPACITIES = ("domain", "sphere", "volume_fraction")


def load(path):
    with open(path) as f:
        return json.load(f)


def relax_stage(c):
    st = [s for s in c["stages"] if s.get("type") == "relax"]
    if len(st) != 1:
        sys.exit(f"expected exactly one relax stage, found {len(st)}")
    return st[0]


def joule_stage(c):
    st = [s for s in c["stages"] if "heat_conduction" in s.get("modules", {})]
    if len(st) > 1:  # a run's scenario: the config's own stage is the one with capacity "domain"
        st = [s for s in st if s["modules"]["heat_conduction"].get("capacity") == "domain"]
    if len(st) != 1:
        sys.exit(f"expected exactly one heat_conduction stage in the config, found {len(st)}")
    return st[0]


def reference(c, n):
    """(r_eq1, R_th, dT_ref) for N particles from the config's geometry and material."""
    g = relax_stage(c)["generator"]
    j = joule_stage(c)["modules"]
    el, he = j["electrical_network"], j["heat_conduction"]
    rd, ld = g["radius"], g["length"]
    vg = math.pi * rd * rd * ld
    r = (0.63 * vg / (4.0 / 3.0 * math.pi * n)) ** (1.0 / 3.0)
    rth = el["resistivity"] * (ld - 2.0 * r) / (math.pi * rd * rd)
    t = joule_stage(c)["stop"]["time"]
    dt = el["voltage"] ** 2 * t / (rth * he["density"] * he["specific_heat"] * vg)
    return r, rth, dt


def run_name(config, n, seed, max_it, max_ov):
    c = load(config)
    g = relax_stage(c)["generator"]
    seed = seed or c.get("seed", 0)
    max_it = max_it or g.get("max_iterations")
    max_ov = max_ov or g.get("max_overlap")
    return f"N{int(n)}_seed{seed}_it{max_it}_ov{max_ov}"


def scenario(config, n, seed, max_it, max_ov):
    json.dump(make_scenario(load(config), n, seed, max_it, max_ov), sys.stdout, indent=1)
    print()


def make_scenario(c, n, seed, max_it, max_ov):
    """The scenario of one run (a dict) from the config `c` (see the module's docstring)."""
    n = int(n)
    if seed:
        c["seed"] = int(seed)
    g = relax_stage(c)["generator"]
    g["particles"] = n
    if max_it:
        g["max_iterations"] = int(max_it)
    if max_ov:
        g["max_overlap"] = float(max_ov)
    r, rth, dt = reference(c, n)
    base = joule_stage(c)
    if base["modules"]["heat_conduction"].get("capacity") != "domain":
        sys.exit("the config's joule stage must use capacity \"domain\"")
    for chk in c.get("checks", []):
        if chk.get("stage") == base["name"] and chk.get("column") == "heat_temperature_mean":
            chk["reference"] = round(dt, 3)
            chk["source"] = re.sub(r"r_mean = [0-9.]+ um \(Eq. 1, N = [0-9]+\)",
                                   f"r_mean = {r * 1e6:.2f} um (Eq. 1, N = {n})", chk.get("source", ""))
    i = c["stages"].index(base)
    extra = []
    for cap in ("sphere", "volume_fraction"):
        st = json.loads(json.dumps(base))
        st["name"] = base["name"] + "_" + cap
        st["modules"]["heat_conduction"]["capacity"] = cap
        extra.append(st)
    c["stages"][i + 1:i + 1] = extra
    c["description"] = (c.get("description", "") + f" [benchmarks/joule_rod: N = {n}; reference {dt:.3f} K; "
                        "extra stages joule_sphere and joule_volume_fraction repeat the joule stage on the same packing "
                        "with only the heat capacity convention changed]")
    return c


def meta(d):
    out = {}
    p = os.path.join(d, "bench_meta.txt")
    if os.path.exists(p):
        for line in open(p):
            k, _, v = line.strip().partition(" ")
            if k == "time_wall_user_sys":
                w, u, s = (float(x) for x in v.split())
                out.update(process_wall_s=w, process_cpu_s=u + s)
            elif k in ("load_start", "load_end"):
                out[k] = v.split()[0]
            elif k == "exit":
                out["exit"] = int(v)
    return out


COLS = ["N", "seed", "max_iterations", "max_overlap", "capacity", "status", "r_eq1_m", "r_mean_m", "R_th_ohm",
        "R_dem_ohm", "R_error_pct", "dT_ref_K", "dT_K", "dT_error_pct", "dT_bk_K", "dT_over_bk_minus_1",
        "heat_capacity_ratio", "heat_capacity_total_J_K", "heat_balance_error", "joule_wall_s", "joule_calls",
        "relax_wall_s", "fire_iterations", "fire_max_force_relative", "max_overlap_ratio", "packing_density",
        "packing_density_interior", "coordination_mean", "process_wall_s", "process_cpu_s", "load_start", "load_end"]


def tabulate(workdir, outdir):
    rows = []
    for d in sorted(glob.glob(os.path.join(workdir, "N*_seed*"))):
        sc_path, sm_path = os.path.join(d, "scenario.json"), os.path.join(d, "out", "summary.json")
        if not os.path.exists(sc_path):
            continue
        c = load(sc_path)
        g = relax_stage(c)["generator"]
        n = int(g["particles"])
        r, rth, dt_ref = reference(c, n)
        base = joule_stage(c)
        el, he = base["modules"]["electrical_network"], base["modules"]["heat_conduction"]
        vg = math.pi * g["radius"] ** 2 * g["length"]
        t = base["stop"]["time"]
        m = meta(d)
        sm = load(sm_path) if os.path.exists(sm_path) else {}
        stages = {s["name"]: s for s in sm.get("stages", [])}
        relax = stages.get(relax_stage(c)["name"], {})
        pk = relax.get("packing", {})
        for cap in T_CAPACITIES:
            name = base["name"] if cap == "domain" else base["name"] + "_" + cap
            st = stages.get(name)
            row = {"N": n, "seed": c.get("seed"), "max_iterations": g.get("max_iterations"), "max_overlap": g.get("max_overlap"),
                   "capacity": cap, "status": sm.get("status", "missing"), "r_eq1_m": r, "R_th_ohm": rth, "dT_ref_K": dt_ref,
                   "relax_wall_s": relax.get("wall_time_s"), "fire_iterations": pk.get("fire_iterations"),
                   "fire_max_force_relative": pk.get("fire_max_force_relative"), "max_overlap_ratio": pk.get("max_overlap_ratio"),
                   "packing_density": pk.get("packing_density"), "packing_density_interior": pk.get("packing_density_interior"),
                   "coordination_mean": pk.get("coordination_mean"), "r_mean_m": pk.get("mean_radius")}
            row.update(m)
            if st and st.get("final"):
                f = st["final"]
                R = f["electrical_resistance"]
                dT = f["heat_temperature_mean"] - he["initial_temperature"]
                bk = el["voltage"] ** 2 * t / (R * he["density"] * he["specific_heat"] * vg)
                row.update(R_dem_ohm=R, R_error_pct=100 * (R - rth) / rth, dT_K=dT, dT_error_pct=100 * (dT - dt_ref) / dt_ref,
                           dT_bk_K=bk, dT_over_bk_minus_1=dT / bk - 1.0, heat_capacity_ratio=f.get("heat_capacity_ratio"),
                           heat_capacity_total_J_K=f.get("heat_capacity_total"), heat_balance_error=f.get("heat_balance_error"),
                           joule_wall_s=st.get("wall_time_s"), joule_calls=st.get("module_calls", {}).get("heat_conduction"))
            else:
                row["status"] = row["status"] if row["status"] != "completed" else "stage missing"
            rows.append(row)
    order = {c: k for k, c in enumerate(T_CAPACITIES)}
    rows.sort(key=lambda r: (r["N"], -(r["max_iterations"] or 0), r["max_overlap"] or 0, order[r["capacity"]]))
    with open(os.path.join(outdir, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLS, extrasaction="ignore")
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in COLS})
    write_md(rows, os.path.join(outdir, "results.md"))
    print(f"{len(rows)} rows -> {outdir}/results.csv, results.md")


def fmt(v, spec):
    if v is None or v == "":
        return "-"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan"
    return format(v, spec)


def write_md(rows, path):
    L = ["# Joule-heated uniform rod (seed 001, section 3.3): sparkdem against the analytic rise", "",
         "Generated by `analyze_joule_rod.py tabulate` from the run directories given; every number below is in",
         "`results.csv`. 304L rod r_d = 1 mm, l_d = 5 mm, 1 V for t = 10 ms, adiabatic, eta = 1, frozen packing.",
         "Reference (fixed before each run, written in its scenario's check): dT_ref = dV^2 t / (R_th rho c V_g),",
         "R_th = rho_e (l_d - 2 r_eq1) / (pi r_d^2), r_eq1 from Eq. 1 for N; band 0.7 % (VALIDATION.md; GranOO 1.4 %).",
         "dT_bk = dV^2 t / (R_dem rho c V_g) uses the DEM's own resistance: dT / dT_bk - 1 is the heating",
         "bookkeeping alone (exactly 0 for capacity `domain`, whose capacities sum to rho c V_g). The variants",
         "`sphere` and `volume_fraction` (GranOO, seed Eq. 13) re-run the same stage on the same packing.",
         "cap ratio = sum V_i / f_v,i over V_g (column heat_capacity_ratio).", ""]
    head = [r for r in rows if r["capacity"] == "domain" and r["max_iterations"] == 20000 and r["max_overlap"] == 0.005]
    if head:
        L += ["## Headline: the config as shipped (relax stop 20000 iterations / overlap 0.005), capacity `domain`", "",
              "| N | R_dem / R_th - 1 [%] | dT / dT_ref - 1 [%] | within 0.7 %? | dT / dT_bk - 1 | relax wall [s] | joule wall [s] | run CPU [s] |",
              "|---|---|---|---|---|---|---|---|"]
        for r in head:
            e = r.get("dT_error_pct")
            L.append("| {} | {} | {} | {} | {} | {} | {} | {} |".format(
                r["N"], fmt(r.get("R_error_pct"), "+.2f"), fmt(e, "+.2f"),
                "-" if e is None else ("yes" if abs(e) <= 0.7 else f"no (misses by {abs(e) - 0.7:.2f} points)"),
                fmt(r.get("dT_over_bk_minus_1"), ".1e"), fmt(r.get("relax_wall_s"), ".0f"), fmt(r.get("joule_wall_s"), ".2f"),
                fmt(r.get("process_cpu_s"), ".0f")))
        L += ["", "Seed 001 (GranOO, N = 5000): about 1.4 %. The rise error is the resistance error: dT / dT_bk - 1 is",
              "round-off, so dT / dT_ref = R_th / R_dem.", ""]
    L += ["## Every run and capacity variant", "",
         "| N | relax stop (it / overlap) | capacity | R_dem [mOhm] | R err vs R_th [%] | dT [K] | dT_ref [K] | dT err [%] | dT / dT_bk - 1 | cap ratio | balance err | joule wall [s] | relax wall [s] | run CPU [s] | FIRE it | max overlap | max force | density |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append("| {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            r["N"], r["max_iterations"], r["max_overlap"], r["capacity"], fmt(r.get("R_dem_ohm") and 1e3 * r["R_dem_ohm"], ".5f"),
            fmt(r.get("R_error_pct"), "+.2f"), fmt(r.get("dT_K"), ".3f"), fmt(r["dT_ref_K"], ".3f"), fmt(r.get("dT_error_pct"), "+.2f"),
            fmt(r.get("dT_over_bk_minus_1"), ".2e"), fmt(r.get("heat_capacity_ratio"), ".4f"), fmt(r.get("heat_balance_error"), ".1e"),
            fmt(r.get("joule_wall_s"), ".2f"), fmt(r.get("relax_wall_s"), ".0f"), fmt(r.get("process_cpu_s"), ".0f"),
            fmt(r.get("fire_iterations"), ".0f"), fmt(r.get("max_overlap_ratio"), ".4f"), fmt(r.get("fire_max_force_relative"), ".4f"),
            fmt(r.get("packing_density"), ".4f")))
    L += ["", "Wall times are from a 2-core machine shared with other jobs (load averages in results.csv), one thread;",
          "run CPU = user + system time of the whole sparkdem process (relax + three joule stages), the steadier figure.",
          "max overlap = largest overlap / smaller radius at the end of the relax; max force = FIRE's largest force",
          "over k / r_mean; the relax stops at max_iterations or when max overlap <= the stop value.", ""]
    with open(path, "w") as f:
        f.write("\n".join(L))


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] in ("run-name", "scenario") and len(sys.argv) == 7:
        if sys.argv[1] == "run-name":
            print(run_name(*sys.argv[2:]))
        else:
            scenario(*sys.argv[2:])
    elif len(sys.argv) == 4 and sys.argv[1] == "tabulate":
        tabulate(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
