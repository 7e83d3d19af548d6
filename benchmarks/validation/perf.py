"""The ledger's perf section (issue 23 item 7): one `perf/...` record per speed or memory figure,
imported from the CSV files the benchmarks write, and the table the README files quote.

    python3 -m tools.validate perf [--ledger FILE] [DOC ...]

replaces ledger["perf"] by the records read from the files below, redraws ledger.md, and rewrites
every `<!-- ledger:table perf -->` block of the DOC files (default: benchmarks/README.md). A record
names its scene, variant, threads, the measured time (or bytes), the ratio it is judged by, the
commit of the binary (the benchmark's own column where it writes one, else the last commit that
changed the CSV) and the source file. Nothing is typed by hand: rerun a benchmark, then this command.

Sources (each optional; a missing file is reported and skipped):
  benchmarks/mechanics/results.csv   sparkdem against LAMMPS, pour and dense bed (median of repeats)
  benchmarks/threads/results.csv     1 against 2 threads, 2 to 1e5 particles, both wait policies
  benchmarks/memory/results.csv      peak memory per particle net of the executable
  benchmarks/sps_nial/profile_summary.json the main scenario run on one thread: its stages'
                                           particle-steps/s and time split (summary.json of
                                           `sparkdem run configs/sps_nial.json --threads 1`,
                                           OMP_WAIT_POLICY=PASSIVE, on a machine otherwise idle
                                           but for short compiles)
  benchmarks/electric_solvers/results.csv  the fastest method per network family at its largest size
                                           with a true error <= 1e-6 (and <= 1e-8)
  benchmarks/ranks/results.csv       sweeps over MPI ranks: wall time at 1 and 2 ranks, efficiency
  benchmarks/electric_solvers/spread.csv  AMG to 1e-8 on 1 and 2 MPI ranks, 1e6 and 4e6 nodes
"""
import csv
import json
import os
import subprocess

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCH = os.path.join(REPO, "benchmarks")


def _rel(path):
    return os.path.relpath(path, REPO)


def _last_commit(path):
    out = subprocess.run(["git", "-C", REPO, "log", "-1", "--format=%h", "--", _rel(path)], capture_output=True,
                         text=True)
    return out.stdout.strip() or "uncommitted"


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def mechanics(path):
    recs = []
    for r in _rows(path):
        recs.append({"id": f"perf/mechanics/{r['scene']}/{r['variant']}", "scene": r["scene"], "variant": r["variant"],
                     "threads": 2 if "_t2" in r["variant"] else 1, "particles": int(r["particles"]),
                     "steps": int(r["steps"]), "figure": "run-loop wall time, median of interleaved repeats",
                     "value": _num(r["loop_s_median"]), "unit": "s", "repeats": int(r["repeats"]),
                     "ratio": _num(r["speedup_vs_lammps_serial"]), "ratio_of": "LAMMPS serial time / this time",
                     "thread_speedup": _num(r.get("thread_speedup")),
                     "physics": f"KE vs LAMMPS: largest difference {r['max_ke_difference_vs_lammps_pct']} % per sample, "
                                f"{r['ke_difference_over_peak_pct']} % of the peak; coordination {r['mean_coordination']}",
                     "commit": r["commit"], "peer": r["lammps"], "load_average": _num(r["load_average_at_start"])})
    return recs


def threads(path):
    recs, commit = [], _last_commit(path)
    for r in _rows(path):
        recs.append({"id": f"perf/threads/{r['family']}/{r['particles']}/{r['wait_policy']}", "scene": r["family"],
                     "variant": f"2 threads, {r['wait_policy']} wait policy", "threads": 2,
                     "particles": int(r["particles"]), "steps": int(r["steps"]),
                     "figure": "wall time per step on 2 threads", "value": _num(r["s_per_step_2_threads"]), "unit": "s/step",
                     "ratio": _num(r["time_2_over_1"]), "ratio_of": "2-thread time / 1-thread time",
                     "commit": commit})
    return recs


def memory(path):
    recs, commit = [], _last_commit(path)
    for r in _rows(path):
        recs.append({"id": f"perf/memory/{r['scene']}", "scene": r["scene"], "variant": "peak RSS net of the executable",
                     "threads": None, "particles": int(r["particles"]), "figure": "bytes per particle",
                     "value": _num(r["net_bytes_per_particle"]), "unit": "B/particle",
                     "ratio": _num(r["net_bytes_per_particle"]) / 2048.0, "ratio_of": "bytes per particle / 2 KB goal",
                     "peak_mb": _num(r["peak_rss_kb"]) / 1024.0, "commit": commit})
    return recs


def sps_nial(path):
    recs, commit = [], _last_commit(path)
    s = json.load(open(path))
    for st in s["stages"]:
        ps = st.get("particle_steps_per_s")
        if not ps:
            continue
        recs.append({"id": f"perf/sps_nial/{st['name']}", "scene": "configs/sps_nial.json", "variant": st["name"],
                     "threads": s.get("threads"), "particles": st.get("particles"), "steps": st.get("steps"),
                     "figure": "stage wall time", "value": st.get("wall_time_s"), "unit": "s",
                     "ratio": ps / 5e6, "ratio_of": "particle-steps/s / 5e6 goal (one thread)",
                     "particle_steps_per_s": ps, "commit": commit})
    return recs


def sps_split(path):
    """Where the main scenario's stepping stages spend their time: the core plan items
    (core_wall_time_s, sampled) and the modules (module_wall_time_s), the rest being checks,
    monitors and output; `ratio` is the share of the stage's wall time."""
    recs, commit = [], _last_commit(path)
    s = json.load(open(path))
    for st in s["stages"]:
        if not st.get("core_wall_time_s"):
            continue
        total = st["wall_time_s"]
        items = dict(st["core_wall_time_s"])
        items.update(st.get("module_wall_time_s", {}))
        items["rest (checks, monitors, output)"] = total - sum(items.values())
        for name, t in sorted(items.items(), key=lambda x: -x[1]):
            if t < 0.01 * total:
                continue
            recs.append({"id": f"perf/sps_nial_split/{st['name']}/{name}", "scene": "configs/sps_nial.json",
                         "variant": name, "threads": s.get("threads"), "particles": st.get("particles"),
                         "steps": st.get("steps"), "figure": "wall time in this part of the stage", "value": t,
                         "unit": "s", "ratio": t / total, "ratio_of": "share of the stage's wall time",
                         "commit": commit})
    return recs


def networks(path):
    recs, commit = [], _last_commit(path)
    rows = [r for r in _rows(path) if r["status"].startswith("ok") and _num(r["V_max_err"]) is not None]
    for family in sorted({r["family"] for r in rows}):
        fam = [r for r in rows if r["family"] == family]
        nodes = max(int(r["nodes"]) for r in fam)
        for tol in (1e-6, 1e-8):
            ok = [r for r in fam if int(r["nodes"]) == nodes and r["reference"] != r["method"]
                  and _num(r["V_max_err"]) <= tol]
            if not ok:
                continue
            best = min(ok, key=lambda r: _num(r["wall_s"]))
            recs.append({"id": f"perf/networks/{family}/{nodes}/err{tol:g}", "scene": f"{family} network",
                         "variant": f"{best['method']} ({best['tolerance_or_beta']})", "threads": None,
                         "particles": nodes, "figure": f"fastest solve with true error <= {tol:g}",
                         "value": _num(best["wall_s"]), "unit": "s", "ratio": _num(best["wall_s"]) / 2.0,
                         "ratio_of": "time / 2 s goal", "reference": best["reference"], "commit": commit})
    return recs


def ranks(path):
    recs = []
    for r in _rows(path):
        scene = os.path.splitext(os.path.basename(r["scene"]))[0]
        recs.append({"id": f"perf/ranks/{scene}/{r['ranks']}", "scene": r["scene"],
                     "variant": f"{r['ranks']} MPI rank(s) x {r['threads_per_rank']} thread", "threads": None,
                     "ranks": int(r["ranks"]), "items": int(r["sweep_items"]), "figure": "whole-run wall time",
                     "value": _num(r["wall_s"]), "unit": "s", "ratio": _num(r["sweep_efficiency"]),
                     "ratio_of": "sweep stages' speed-up / ranks", "run_efficiency": _num(r["efficiency"]),
                     "equal_to_1_rank": r["tables_equal_to_1_rank"] == "True", "commit": r["commit"],
                     "load_average": _num(r["load_average_at_start"])})
    return recs


def spread(path):
    recs = []
    rows = _rows(path)
    one = {(r["family"], r["nodes"]): _num(r["wall_s"]) for r in rows if r["method"] == "amg"}
    for r in rows:
        ranks = 1 if r["method"] == "amg" else int(r["method"].replace("amg_spread", ""))
        base = one.get((r["family"], r["nodes"]))
        recs.append({"id": f"perf/networks_ranks/{r['family']}/{r['nodes']}/{ranks}", "scene": f"{r['family']} network",
                     "variant": f"amg ({r['tolerance_or_beta']}) on {ranks} MPI rank(s)", "threads": 1, "ranks": ranks,
                     "particles": int(r["nodes"]), "figure": "solve wall time (set-up included)",
                     "value": _num(r["wall_s"]), "unit": "s", "ratio": base / _num(r["wall_s"]) if base else None,
                     "ratio_of": "1-rank time / this time", "G_rel_err": _num(r["G_rel_err"]),
                     "V_max_err": _num(r["V_max_err"]), "reference": r["reference"], "commit": r["commit"]})
    return recs


SOURCES = [("mechanics/results.csv", mechanics), ("threads/results.csv", threads), ("memory/results.csv", memory),
           ("sps_nial/profile_summary.json", sps_nial), ("sps_nial/profile_summary.json", sps_split),
           ("electric_solvers/results.csv", networks), ("ranks/results.csv", ranks),
           ("electric_solvers/spread.csv", spread)]


def collect():
    """All perf records of the benchmark files present; returns (records, notes about missing files)."""
    recs, notes = [], []
    for rel, fn in SOURCES:
        path = os.path.join(BENCH, rel)
        if not os.path.exists(path):
            notes.append(f"perf: {_rel(path)} not found, skipped")
            continue
        for r in fn(path):
            r["source"] = _rel(path)
            recs.append(r)
    return recs, notes


def _fmt(x, digits=4):
    if x is None:
        return ""
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def table(ledger, full=True):
    """The perf records as one markdown table (the ids say where each comes from); without `full`,
    the thread records of scenes under 1e4 particles are left to ledger.md."""
    lines = ["| record | particles / nodes | threads | value | ratio | ratio of | commit |", "|---|---|---|---|---|---|---|"]
    for r in ledger.get("perf", []):
        if not full and r["id"].startswith("perf/threads/") and (r.get("particles") or 0) < 10000:
            continue
        lines.append(f"| {r['id']} | {_fmt(r.get('particles'))} | {_fmt(r.get('threads'))} | "
                     f"{_fmt(r.get('value'))} {r.get('unit', '')} | {_fmt(r.get('ratio'), 3)} | {r.get('ratio_of', '')} | "
                     f"{r.get('commit', '')} |")
    return "\n".join(lines)
