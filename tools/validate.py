#!/usr/bin/python3
"""sparkdem's validation runner and ledger (benchmarks/validation/README.md).
Run from the repository root as `/usr/bin/python3 -m tools.validate CMD` (`validate CMD` below;
tools/ and benchmarks/ are packages, docs/running.md, "Python tools"):

    validate list                           the cases, their tiers, sizes and seeds
    validate run --tier fast|full [--case GLOB ...] [--sizes N ...] [--seeds S ...]
            [--jobs J] [--workdir DIR] [--ledger FILE] [--sparkdem PATH] [--build DIR]
            [--reuse] [--no-record] [--provisional] [--strict]
    validate report [--ledger FILE]         ledger.md and error_vs_time.png
    validate recompute [--write]            every record rebuilt from its run file (runs/)
    validate check-ledger                   fail on a dirty record, a cleared mark, a NaN
    validate rebase --case GLOB --why TEXT [--seen]  new first config values (marks never cleared)
    validate check-hashes [--ledger FILE]   fail when a recorded config changed
    validate check-docs FILE...             fail when a quoted figure is not the ledger's
    validate derive-bands --case GLOB --seeds S ...  fast-tier bands from measured scatter

The ledger's perf section (speed and memory) is made by its twin, tools/perf.py.

The table of cases is benchmarks/validation/cases.py: each case names its configs, how a run's
scenario is made from them (N and the packing seed patched), and the figures it yields with their
references (fixed before the run), bands and sources. This file owns everything the cases share:
patching and writing scenarios, running sparkdem (timed: wall and CPU), reusing finished runs,
ensemble statistics, the ledger records, the staleness guard (config hashes) and the reports.

Exit codes: 0 done (without --strict, whatever the figures); 1 with --strict, a figure outside its band
or a run that failed (the ctests of the fast tier pass --strict); 2 bad arguments or set-up errors.
"""
import argparse
import concurrent.futures as futures
import fnmatch
import hashlib
import json
import math
import os
import re
import statistics
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VALDIR = os.path.join(REPO, "benchmarks", "validation")
LEDGER = os.path.join(VALDIR, "ledger.json")
FAST_BANDS = os.path.join(VALDIR, "fast_bands.json")
from benchmarks.validation import cases as case_table  # noqa: E402
from tools import ledger as rules  # noqa: E402  (kinds, verdicts, marks, the ledger's checks)


# ---------------------------------------------------------------- configs and hashes

def load_json(path):
    with open(path) as f:
        return json.load(f)


write_json_atomic = rules.write_json_atomic  # strict JSON (no NaN), temporary name then rename


def included_files(path):
    """`path` and every file it pulls in through "$include" (recursively), repository-relative."""
    out, todo = [], [os.path.abspath(path)]
    while todo:
        p = todo.pop()
        rel = os.path.relpath(p, REPO)
        if rel in out:
            continue
        out.append(rel)

        def walk(x, base=os.path.dirname(p)):
            if isinstance(x, dict):
                if isinstance(x.get("$include"), str):
                    todo.append(os.path.normpath(os.path.join(base, x["$include"])))
                for v in x.values():
                    walk(v)
            elif isinstance(x, list):
                for v in x:
                    walk(v)
        if p.endswith(".json"):
            walk(load_json(p))
    return sorted(out)


def file_hash(rel):
    with open(os.path.join(REPO, rel), "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


def config_hashes(case):
    files = set()
    for c in case.configs:
        files.update(included_files(os.path.join(REPO, c)))
    return {f: file_hash(f) for f in sorted(files)}


def flatten(x, prefix=""):
    """{JSON pointer: leaf value} of a JSON document."""
    if isinstance(x, dict):
        out = {}
        for k, v in x.items():
            out.update(flatten(v, prefix + "/" + str(k)))
        return out
    if isinstance(x, list):
        out = {}
        for i, v in enumerate(x):
            out.update(flatten(v, prefix + "/" + str(i)))
        return out
    return {prefix: x}


def config_values(case):
    """Every leaf of every config file the case uses, as {file#pointer: value}."""
    vals = {}
    for rel in config_hashes(case):
        if rel.endswith(".json"):
            for k, v in flatten(load_json(os.path.join(REPO, rel))).items():
                if not (k.endswith("/description") or k.endswith("/source") or "/_comment" in k):
                    vals[rel + "#" + k] = v
    return vals


def git_commit():
    try:
        c = subprocess.run(["git", "-C", REPO, "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True,
                           check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True).stdout.strip()
        return c + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


# ---------------------------------------------------------------- running sparkdem

class Runner:
    """Runs one scenario in its own directory: scenario.json, out/, sparkdem.log, meta.json (exit code,
    wall and CPU seconds, load average). A finished run whose scenario and binary are unchanged is kept
    with --reuse."""

    def __init__(self, sparkdem, build, threads, reuse):
        # absolute: tools run with their run directory as working directory
        self.sparkdem, self.build = os.path.abspath(sparkdem), os.path.abspath(build)
        self.threads, self.reuse = threads, reuse
        with open(sparkdem, "rb") as f:
            self.binary_hash = hashlib.sha256(f.read()).hexdigest()[:16]
        helptext = subprocess.run([sparkdem, "run", "--help"], capture_output=True, text=True).stdout
        self.report_only = ["--report-only"] if "--report-only" in helptext else []
        # the code the runs use: the commit the binary was built from and whether its tree was clean
        self.commit, self.clean = rules.binary_build(sparkdem)

    def tool(self, rel):
        p = os.path.join(self.build, rel)
        if not os.access(p, os.X_OK):
            raise RuntimeError(f"{p} not found: build it (cmake --build {self.build} --target {os.path.basename(rel)}_exe "
                               f"or --target {os.path.basename(rel)})")
        return p

    def run(self, scene, rundir, name="scenario"):
        """Runs sparkdem on `scene` (a dict) in rundir; returns the meta dict (rc, wall_s, cpu_s)."""
        os.makedirs(rundir, exist_ok=True)
        text = json.dumps(scene, indent=1)
        spath, mpath = os.path.join(rundir, name + ".json"), os.path.join(rundir, name + ".meta.json")
        out = os.path.join(rundir, "out" if name == "scenario" else name + "_out")
        if self.reuse and os.path.exists(mpath) and os.path.exists(spath):
            meta = load_json(mpath)
            if open(spath).read() == text and meta.get("binary") == self.binary_hash and meta.get("rc") in (0, 5):
                meta["reused"] = True
                return meta
        with open(spath, "w") as f:
            f.write(text)
        cmd = [self.sparkdem, "run", spath, "-o", out, "--threads", str(self.threads), "--quiet"] + self.report_only
        return self.command(cmd, rundir, name, mpath)

    def command(self, cmd, rundir, name, mpath=None, extra_env=None):
        os.makedirs(rundir, exist_ok=True)
        env = dict(os.environ, OMP_NUM_THREADS=str(self.threads), OMP_WAIT_POLICY="PASSIVE", **(extra_env or {}))
        load0 = os.getloadavg()[0]
        t0 = time.time()
        with open(os.path.join(rundir, name + ".log"), "w") as log, open(os.path.join(rundir, name + ".err"), "w") as err:
            proc = subprocess.Popen(cmd, stdout=log, stderr=err, env=env, cwd=rundir)
            # wait4: this child's own CPU time (RUSAGE_CHILDREN would mix in the runs of other jobs)
            _, status, usage = os.wait4(proc.pid, 0)
            proc.returncode = rc = os.waitstatus_to_exitcode(status)
        meta = {"rc": rc, "wall_s": time.time() - t0, "cpu_s": usage.ru_utime + usage.ru_stime,
                "load_start": load0, "load_end": os.getloadavg()[0], "binary": self.binary_hash,
                "command": " ".join(cmd)}
        write_json_atomic(mpath or os.path.join(rundir, name + ".meta.json"), meta)
        return meta


class RunContext:
    """What a case's run function gets: its directory, N, seed and the runner."""

    def __init__(self, runner, rundir, n, seed, tier):
        self.runner, self.rundir, self.n, self.seed, self.tier = runner, rundir, n, seed, tier
        self.wall_s = 0.0
        self.cpu_s = 0.0
        self.load = os.getloadavg()[0]  # load average when the run started (timings are noisy above the core count)

    def config(self, rel):
        """A config with its $include paths made absolute, so the copy runs from anywhere."""
        from tools.sps_outputs import absolute_includes  # numpy: imported only when running
        path = os.path.join(REPO, rel)
        c = load_json(path)
        absolute_includes(c, os.path.dirname(path))
        return c

    def sparkdem(self, scene, name="scenario"):
        meta = self.runner.run(scene, self.rundir, name)
        self.wall_s += meta["wall_s"]
        self.cpu_s += meta["cpu_s"]
        if meta["rc"] not in (0, 5):  # 5: a banded check of the scene missed (the ledger judges)
            raise RuntimeError(f"sparkdem exited with {meta['rc']}: see {os.path.join(self.rundir, name + '.err')}")
        return os.path.join(self.rundir, "out" if name == "scenario" else name + "_out")

    def command(self, cmd, name, extra_env=None):
        """Runs a reference or benchmark tool in the run directory (extra_env: more environment
        variables); returns the path of its standard output."""
        meta = self.runner.command(cmd, self.rundir, name, extra_env=extra_env)
        self.wall_s += meta["wall_s"]
        self.cpu_s += meta["cpu_s"]
        if meta["rc"] != 0:
            raise RuntimeError(f"{cmd[0]} exited with {meta['rc']}: see {os.path.join(self.rundir, name + '.err')}")
        return os.path.join(self.rundir, name + ".log")  # its standard output


def run_one(runner, case, tier, n, seed, workdir):
    rundir = os.path.join(workdir, tier, case.id.replace("/", "_"), f"N{n}_seed{seed}")
    ctx = RunContext(runner, rundir, n, seed, tier)
    try:
        figures = case.run(ctx)
        err = None
    except (Exception, SystemExit) as e:  # a failed run is reported in its record, never silently dropped
        figures, err = {}, f"{type(e).__name__}: {e}"
    return {"n": n, "seed": seed, "figures": figures, "error": err, "wall_s": ctx.wall_s, "cpu_s": ctx.cpu_s,
            "load": ctx.load,
            "rundir": os.path.relpath(rundir, REPO) if rundir.startswith(REPO) else rundir}


# ---------------------------------------------------------------- records

def ensemble(runs, fig, absolute=False):
    """Statistics of figure `fig` over the runs that produced it; the error is relative to the
    reference, or (absolute) measured - reference in the figure's unit."""
    have = [r for r in runs if fig in r["figures"]]
    if not have:
        return None
    unevaluated = [r["seed"] for r in have if not is_finite(r["figures"][fig]["measured"])]
    have = [r for r in have if r["seed"] not in unevaluated]
    if not have:  # every run gave NaN or nothing: null with its reason, never a NaN in the ledger
        return {"measured": None, "count": 0, "null_reason": f"the figure could not be evaluated in any run "
                f"(seeds {unevaluated}: not finite or missing in the run's output)"}
    per_seed = [{"seed": r["seed"], "measured": r["figures"][fig]["measured"],
                 "reference": r["figures"][fig]["reference"]} for r in have]
    for p in per_seed:
        p["error"] = (p["measured"] - p["reference"]) / (1.0 if absolute else abs(p["reference"]))
    errs = [p["error"] for p in per_seed]
    out = {"measured": statistics.fmean(p["measured"] for p in per_seed),
           "reference": statistics.fmean(p["reference"] for p in per_seed),
           "error": statistics.fmean(errs), "count": len(have), "per_seed": per_seed}
    out["mean"] = out["error"]
    out["std"] = statistics.stdev(errs) if len(errs) > 1 else None
    if unevaluated:
        out["null_reason"] = f"not evaluated in seeds {unevaluated} (left out of the statistics)"
    for r in have:
        for k, x in r["figures"][fig].get("extra", {}).items():
            out.setdefault("extra", {}).setdefault(k, []).append(x)
    return out


def is_finite(x):
    return isinstance(x, (int, float)) and math.isfinite(x)


def tuned_by_config_change(case, first_values):
    """Config keys of the case changed since its first record: each is a tuning after seeing."""
    now = config_values(case)
    out = []
    for k in sorted(set(now) | set(first_values)):
        if now.get(k) != first_values.get(k):
            out.append({"parameter": k, "why": f"changed after the case's first record: {first_values.get(k)!r} -> "
                                               f"{now.get(k)!r} (automatic mark)"})
    return out


def run_meta(runner, provisional):
    """What every record of one `run` invocation shares: the binary's provenance and the date."""
    return {"threads": runner.threads, "commit": runner.commit, "clean": runner.clean, "binary": runner.binary_hash,
            "provisional": bool(provisional), "date": time.strftime("%Y-%m-%d %H:%M:%S")}


def make_record(case, fig, tier, n, runs, meta, first_values, fast_bands, marks=()):
    """The record of figure `fig` from its runs (the same from a fresh run and from a run file:
    `recompute`). meta: run_meta's fields (or a run file's); marks: the figure's permanent tuned marks."""
    st = ensemble(runs, fig.key, fig.absolute)
    failed = [r for r in runs if r["error"]]
    tuned = list(fig.tuned) + tuned_by_config_change(case, first_values)
    tuned += [m for m in marks if m not in tuned]
    rec = {"case": fig.id, "source": fig.source, "reference_origin": fig.reference_origin,
           "kind": rules.record_kind(fig, tier, n), "tier": tier, "N": n,
           "seeds": [r["seed"] for r in runs], "calibrated_on": fig.calibrated_on,
           "wall_s": round(sum(r["wall_s"] for r in runs), 2), "cpu_s": round(sum(r["cpu_s"] for r in runs), 2),
           "threads": meta["threads"], "commit": meta["commit"], "clean": meta["clean"], "date": meta["date"],
           "configs": meta["configs"], "variants": fig.variants,
           **({"shares_values_with": fig.shares_values_with} if fig.shares_values_with else {}),
           **({"error_kind": "absolute"} if fig.absolute else {}),
           **({"provisional": True} if meta.get("provisional") else {}),
           "tuned_after_seeing": tuned,
           "runs": [{"seed": r["seed"], "rundir": r["rundir"], "wall_s": round(r["wall_s"], 2),
                     "cpu_s": round(r["cpu_s"], 2), "load_average_start": round(r["load"], 2), "error": r["error"]}
                    for r in runs]}
    if failed:
        rec["failed_runs"] = len(failed)
    if st is None or st["measured"] is None:
        rec.update({"measured": None, "error": None, "pass": False, "band": fig.band_at(n),
                    "null_reason": (st or {}).get("null_reason", "no run produced the figure")})
        rec["verdict"] = rules.verdict(rec)
        return rec
    rec.update({k: st[k] for k in ("measured", "reference", "error", "mean", "std", "count", "per_seed")})
    for k in ("extra", "null_reason"):
        if k in st:
            rec[k] = st[k]
    if tier == "full":
        judge_full(rec, fig)
    else:
        judge_fast(rec, fig, n, fast_bands, failed)
    rec["verdict"] = rules.verdict(rec)
    return rec


def judge_fast(rec, fig, n, fast_bands, failed):
    """A fast-tier record: inside or outside its regression band (never a pass)."""
    rec["pass"] = False
    if rec["kind"] == "construction":
        rec["band"] = None
        return
    fb = fast_bands.get(f"{fig.id}@N{n}")
    if fb is None and fig.min_seeds == 1:  # deterministic (no packing): the closed form's own band
        fb = {"center": 0.0, "halfwidth": fig.band_at(n),
              "derivation": "the validation band: a deterministic case has no scatter to derive one from"}
    if fb is None:
        rec.update({"band": None, "inside_band": False, "note": "no fast band derived for this size "
                    "(python3 -m tools.validate derive-bands)"})
        return
    lo, hi = fb["center"] - fb["halfwidth"], fb["center"] + fb["halfwidth"]
    rec["band"] = {"error_range": [lo, hi], "derivation": fb["derivation"]}
    rec["inside_band"] = lo <= rec["error"] <= hi and not failed


def judge_full(rec, fig):
    """Band and verdict of a full-tier record from its figure's definition in cases.py: only a
    validation record passes; a calibration record reports its residual against the band."""
    band = fig.band_at(rec["N"])
    rec["band"] = band
    rec.pop("note", None)
    if rec["kind"] == "construction":
        rec["pass"] = False
        return
    inside = (abs(rec["error"]) <= band and not rec.get("failed_runs") and rec["count"] >= fig.min_seeds)
    if rec["kind"] in ("calibration", "study"):
        rec["pass"], rec["inside_band"] = False, inside
    else:
        rec["pass"] = inside and not rec["tuned_after_seeing"] and not rec.get("provisional")
    if rec["count"] < fig.min_seeds:
        rec["note"] = f"{rec['count']} packing(s): a packing decides this figure, >= {fig.min_seeds} needed for a pass"
    rec["scatter_exceeds_band"] = rec["std"] is not None and rec["std"] > band


RECOMPUTED_FIELDS = ("kind", "measured", "reference", "error", "mean", "std", "count", "per_seed", "extra", "band",
                     "pass", "inside_band", "verdict", "tuned_after_seeing", "wall_s", "cpu_s", "commit", "clean",
                     "provisional", "null_reason", "shares_values_with")


def run_file_path(ledger_path, tier, case_id, n):
    """Where a run's small result file lives: runs/ beside the ledger, one file per case, tier and N."""
    return os.path.join(os.path.dirname(os.path.abspath(ledger_path)), "runs", tier, case_id.replace("/", "_"),
                        f"N{n}.json")


def write_run_file(path, case, tier, n, runs, meta):
    """The inputs of every figure of one case, tier and N: per run its seed, figures (measured,
    reference, side figures), error, wall and CPU seconds; with the binary's provenance and the
    configs' hashes. `recompute` rebuilds the records from it without running sparkdem."""
    body = {"case": case.id, "tier": tier, "N": n, **meta, "configs": config_hashes(case),
            "runs": [{k: r[k] for k in ("seed", "figures", "error", "wall_s", "cpu_s", "load", "rundir")} for r in runs]}
    write_json_atomic(path, body)


def records_from_run_file(ledger, path, ledger_path, fast_bands):
    """The records of every figure of a run file, made as `run` made them."""
    rf = rules.load_strict(path)
    case = next((c for c in case_table.CASES if c.id == rf["case"]), None)
    if case is None:
        raise ValueError(f"{path}: case {rf['case']} is not in benchmarks/validation/cases.py")
    first = ledger.get("first_config_values", {}).get(case.id) or config_values(case)
    runs = [dict(r, n=rf["N"]) for r in rf["runs"]]
    out = []
    for fig in case.figures:
        if not fig.applies(rf["tier"], rf["N"]):
            continue
        rec = make_record(case, fig, rf["tier"], rf["N"], runs, rf, first, fast_bands,
                          ledger.get("tuned_marks", {}).get(fig.id, []))
        rec["run_file"] = os.path.relpath(path, os.path.dirname(os.path.abspath(ledger_path)))
        out.append(rules.finite(rec))
    return out


def cmd_recompute(a):
    """Rebuilds every record that has a run file from that file alone (no sparkdem run) and compares
    it with the ledger; --write stores the recomputed records (after a new tuned mark, a corrected
    band or fast band). Exit 1 when a record differs (without --write) or a run file is missing."""
    lock = ledger_lock(a.ledger) if a.write else None
    ledger = load_ledger(a.ledger)
    recs = {(r["case"], r["tier"], r["N"]): r for r in ledger["records"]}
    bad, n_same, files = [], 0, sorted({r["run_file"] for r in ledger["records"] if r.get("run_file")})
    fast_bands = load_json(FAST_BANDS) if os.path.exists(FAST_BANDS) else {}
    for rel in files:
        path = os.path.join(os.path.dirname(os.path.abspath(a.ledger)), rel)
        if not os.path.exists(path):
            bad.append(f"{rel}: missing")
            continue
        for new in records_from_run_file(ledger, path, a.ledger, fast_bands):
            old = recs.get((new["case"], new["tier"], new["N"]))
            diff = [k for k in RECOMPUTED_FIELDS if (old or {}).get(k) != new.get(k)]
            if old is None or diff:
                bad.append(f"{new['case']} N={new['N']} ({new['tier']}): "
                           + ("not in the ledger" if old is None else "differs in " + ", ".join(diff)))
                if a.write:
                    store(ledger, new)
            else:
                n_same += 1
    legacy = sum(1 for r in ledger["records"] if r.get("legacy"))
    print(f"recompute: {len(files)} run files, {n_same} records equal to the ledger, {len(bad)} differ; "
          f"{legacy} legacy records without run files")
    for line in bad:
        print("  " + line, file=sys.stderr)
    if a.write:
        write_json_atomic(a.ledger, ledger)
        write_reports(ledger, os.path.dirname(os.path.abspath(a.ledger)))
        lock.close()
        return 0
    return 1 if bad else 0


def cmd_check_ledger(a):
    """The ledger's rules (tools/ledger.py: check_rules) on FILE, against the committed ledger's marks."""
    ledger = rules.load_strict(a.ledger)
    head = None
    rel = os.path.relpath(os.path.abspath(a.ledger), REPO)
    try:  # the committed ledger (no git, or not a checkout: the marks are checked against the file alone)
        shown = subprocess.run(["git", "-C", REPO, "show", f"HEAD:{rel}"], capture_output=True, text=True)
    except OSError:
        shown = None
    if shown is not None and shown.returncode == 0 and not a.no_head:
        head = json.loads(shown.stdout, parse_constant=lambda t: None)
    bad = rules.check_rules(ledger, head, os.path.dirname(os.path.abspath(a.ledger)))
    for line in bad:
        print(line, file=sys.stderr)
    print(f"check-ledger: {len(ledger['records'])} records, {len(bad)} broken rules")
    return 1 if bad else 0


def cmd_rebase(a):
    """Takes the current configs of the selected cases as their new first values (the reference of the
    automatic tuned_after_seeing marks), for a model or protocol change decided from sources and from
    figures other than the case's own (an issue's build step), before the case's runs on it. Recorded
    in the ledger's `rebases` with the date, the commit, the keys that changed and why.
    A rebase never clears a mark: the marks its records carry become permanent first, and with --seen
    (or a reason that says the change was decided after seeing a figure of the case) every changed
    key becomes a permanent mark of each of the case's figures."""
    if not a.why.strip():
        raise SystemExit("rebase needs --why")
    if not a.seen and rules.reason_says_seen(a.why):
        print("validate: the reason says the change was decided after seeing a figure of the case; rebase "
              "with --seen, which marks its figures tuned", file=sys.stderr)
        return 2
    lock = ledger_lock(a.ledger)
    ledger = load_ledger(a.ledger)
    fv = ledger.setdefault("first_config_values", {})
    for case in selected(a.case):
        now = config_values(case)
        old = fv.get(case.id, {})
        changed = sorted(k for k in set(old) | set(now) if old.get(k) != now.get(k))
        for fig in case.figures:
            for r in ledger["records"]:
                if r["case"] == fig.id:
                    rules.add_marks(ledger, fig.id, r.get("tuned_after_seeing") or [])
            if a.seen:
                rules.add_marks(ledger, fig.id, [{"parameter": k, "why": f"changed after seeing a figure of the case "
                                                  f"(rebase {time.strftime('%Y-%m-%d')}: {a.why})"} for k in changed])
        fv[case.id] = now
        ledger.setdefault("rebases", []).append({"case": case.id, "date": time.strftime("%Y-%m-%d %H:%M:%S"),
                                                 "commit": git_commit(), "why": a.why, "changed": changed,
                                                 "seen": bool(a.seen)})
        print(f"{case.id}: rebased ({len(changed)} config keys changed since the first values"
              + (", marked tuned)" if a.seen else ")"))
    for r in ledger["records"]:
        rules.carry_marks(ledger, r)
    write_json_atomic(a.ledger, ledger)
    write_reports(ledger, os.path.dirname(os.path.abspath(a.ledger)))
    lock.close()
    return 0


def first_values_of(ledger, case):
    fv = ledger.setdefault("first_config_values", {})
    if case.id not in fv:
        fv[case.id] = config_values(case)
    return fv[case.id]


def store(ledger, rec):
    """Replace the record of the same case, tier and N (the ledger keeps the latest). The marks the
    old record carried become permanent marks of the figure first: a rerun never clears one."""
    for r in ledger["records"]:
        if r["case"] == rec["case"]:
            rules.add_marks(ledger, r["case"], r.get("tuned_after_seeing") or [])
    rules.add_marks(ledger, rec["case"], rec.get("tuned_after_seeing") or [])
    rules.carry_marks(ledger, rec)
    recs = [r for r in ledger["records"]
            if not (r["case"] == rec["case"] and r["tier"] == rec["tier"] and r["N"] == rec["N"])]
    recs.append(rec)
    recs.sort(key=lambda r: (r["case"], r["tier"], r["N"]))
    ledger["records"] = recs


def ledger_lock(path):
    """An exclusive lock on PATH.lock held while a run reads, updates and writes the ledger."""
    import fcntl
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    f = open(path + ".lock", "w")
    fcntl.flock(f, fcntl.LOCK_EX)
    return f


def load_ledger(path):
    if os.path.exists(path):
        return rules.load_strict(path)
    return {"schema": "benchmarks/validation/README.md", "records": [], "first_config_values": {}}


# ---------------------------------------------------------------- commands

def selected(patterns, tier=None):
    out = []
    for c in case_table.CASES:
        if patterns and not any(fnmatch.fnmatch(c.id, p) or any(fnmatch.fnmatch(f.id, p) for f in c.figures)
                                for p in patterns):
            continue
        if tier and tier not in c.tiers:
            continue
        out.append(c)
    return out


def cmd_list(a):
    if a.ids:  # one case id per line (tests/CMakeLists.txt makes one ctest per fast case)
        print("\n".join(c.id for c in case_table.CASES if a.ids in c.tiers))
        return 0
    for c in case_table.CASES:
        for t, spec in c.tiers.items():
            print(f"{c.id:34s} {t:5s} N={spec['sizes']} seeds={spec['seeds']}  figures: "
                  + ", ".join(f.id for f in c.figures))
    return 0


def refuse_dirty(runner, a):
    """A message when `run` would record from a binary not built from a clean commit, else None."""
    if a.no_record or a.provisional or runner.clean:
        return None
    return (f"validate: refusing to record: {a.sparkdem} was built from commit {runner.commit} with a dirty work "
            f"tree (`sparkdem --version`). Commit, rebuild (cmake --build build), then run; or pass --provisional "
            f"(records marked so, never counted) or --no-record.")


def cmd_run(a):
    cases = selected(a.case, a.tier)
    if not cases:
        print(f"validate: no case of tier {a.tier} matches {a.case}", file=sys.stderr)
        return 2
    runner = Runner(a.sparkdem, a.build, a.threads, a.reuse)
    refusal = refuse_dirty(runner, a)
    if refusal:
        print(refusal, file=sys.stderr)
        return 2
    jobs = [(c, n, s) for c in cases for n in (a.sizes or c.tiers[a.tier]["sizes"])
            for s in (a.seeds or c.tiers[a.tier]["seeds"])]
    print(f"validate: tier {a.tier}, {len(jobs)} runs of {len(cases)} cases, {a.jobs} at a time, "
          f"{a.threads} thread(s) each; binary of commit {runner.commit} ({'clean' if runner.clean else 'dirty'}); "
          f"load average {os.getloadavg()[0]:.2f}; workdir {a.workdir}", flush=True)
    results = run_jobs(runner, jobs, a)
    lock = ledger_lock(a.ledger) if not a.no_record else None  # other runs may record into the same ledger
    ledger = load_ledger(a.ledger)
    fast_bands = load_json(FAST_BANDS) if os.path.exists(FAST_BANDS) else {}
    meta = run_meta(runner, a.provisional)
    misses = 0
    for c in cases:
        first = first_values_of(ledger, c)
        meta["configs"] = config_hashes(c)
        for n in (a.sizes or c.tiers[a.tier]["sizes"]):
            runs = sorted(results.get((c.id, n), []), key=lambda r: r["seed"])
            rf = run_file_path(a.ledger, a.tier, c.id, n)
            if not a.no_record:
                write_run_file(rf, c, a.tier, n, runs, meta)
            for fig in c.figures:
                if not fig.applies(a.tier, n):
                    continue
                rec = rules.finite(make_record(c, fig, a.tier, n, runs, meta, first, fast_bands,
                                               ledger.get("tuned_marks", {}).get(fig.id, [])))
                rec["run_file"] = os.path.relpath(rf, os.path.dirname(os.path.abspath(a.ledger)))
                print("  " + summary_line(rec))
                if rec["verdict"].split(", ")[-1] in ("miss", "failed", "outside band"):
                    misses += 1
                if not a.no_record:
                    store(ledger, rec)
    if not a.no_record:
        write_json_atomic(a.ledger, ledger)
        if not a.no_report:
            write_reports(ledger, os.path.dirname(os.path.abspath(a.ledger)))
    if lock:
        lock.close()
    if misses and a.strict:
        print(f"validate: {misses} figure(s) outside their band", file=sys.stderr)
        return 1
    return 0


def run_jobs(runner, jobs, a):
    """Runs (case, N, seed) jobs, a.jobs at a time; returns {(case id, N): [run results]}."""
    results = {}
    with futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        fut = {pool.submit(run_one, runner, c, a.tier, n, s, a.workdir): (c, n, s) for c, n, s in jobs}
        for f in futures.as_completed(fut):
            c, n, s = fut[f]
            r = f.result()
            results.setdefault((c.id, n), []).append(r)
            status = r["error"] or ", ".join(
                (f"{k} {100 * (v['measured'] - v['reference']) / abs(v['reference']):+.2f} %" if v["reference"]
                 else f"{k} {v['measured'] - v['reference']:+.4g} (absolute)")
                if is_finite(v["measured"]) else f"{k} not evaluated" for k, v in r["figures"].items())
            print(f"  {c.id} N={n} seed={s}: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU: {status}", flush=True)
    return results


def fmt_err(rec, x):
    """An error of a record: in % (relative) or as a signed number in the figure's unit (absolute)."""
    if rec.get("error_kind") == "absolute" and x is not None:
        return f"{x:+.4f}"
    return fmt_pct(x)


def fmt_std(rec, x):
    return f"{x:.4f}" if rec.get("error_kind") == "absolute" else f"{100 * x:.2f}"


def fmt_pct(x):
    if x is None:
        return "n/a"
    if x != 0 and abs(x) < 5e-5:
        return f"{100 * x:+.1e} %"
    return f"{100 * x:+.2f} %"


def band_text(rec):
    b = rec.get("band")
    if b is None:
        return "none"
    if isinstance(b, dict):
        lo, hi = b["error_range"]
        return f"[{100 * lo:+.3g}, {100 * hi:+.3g}] %"
    if rec.get("error_kind") == "absolute":
        return f"±{b:g} (absolute)"
    return f"±{100 * b:g} %"


def summary_line(rec):
    std = f" ± {fmt_std(rec, rec['std'])}" if rec.get("std") is not None else ""
    return (f"{rec['verdict'].upper():12s} {rec['case']} N={rec['N']} ({rec['kind']}): error "
            f"{fmt_err(rec, rec.get('error'))}{std} over {rec.get('count', 0)} run(s), band {band_text(rec)}, "
            f"{rec['wall_s']:.1f} s wall")


verdict = rules.verdict


def write_reports(ledger, outdir):
    write_markdown(ledger, os.path.join(outdir, "ledger.md"))
    try:
        from benchmarks.validation import plot as ledger_plot  # matplotlib
        ledger_plot.write_error_vs_time(ledger["records"], os.path.join(outdir, "error_vs_time.png"), verdict)
    except ImportError as e:
        print(f"validate: error_vs_time.png not drawn ({e}); install python3-matplotlib", file=sys.stderr)


def table_rows(ledger, kind):
    """The records a generated table of `kind` shows (legacy and provisional records apart)."""
    recs = ledger["records"]
    live = [r for r in recs if not r.get("legacy") and not r.get("provisional")]
    if kind == "calibration":
        return [r for r in live if r["kind"] in ("calibration", "construction")]
    if kind in ("legacy", "provisional"):
        return [r for r in recs if r.get(kind)]
    return [r for r in live if r["kind"] == kind]


def ledger_table(ledger, kind, changed=None):
    """A generated markdown table: kind validation, calibration (with construction), study, regression,
    legacy, provisional, headline, commits or perf. changed: {commit: "yes"/"no"/"unknown"} adds
    the column "engine/ or physics/ changed since" (ledger.md only: it moves with every commit)."""
    if kind.startswith("perf"):  # "perf" (every perf case) or "perf CASE" (tools/perf.py list)
        return rules.perf_table(ledger, full=False, case=kind[5:] or None)
    if kind == "headline":
        return headline_table(ledger)
    if kind == "commits":
        return commits_table(ledger)
    cols = ["case", "N", "seeds", "reference", "measured", "error (mean ± std)", "band", "verdict", "wall [s]",
            "CPU [s]", "commit"] + (["engine/physics changed since"] if changed is not None else [])
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in table_rows(ledger, kind):
        ref = "n/a" if r.get("reference") is None else f"{r['reference']:.6g}"
        meas = "n/a" if r.get("measured") is None else f"{r['measured']:.6g}"
        flag = " (scatter > band)" if r.get("scatter_exceeds_band") else ""
        cells = [r["case"], r["N"], len(r["seeds"]), ref, meas, f"{fmt_err(r, r.get('error'))}{std_text(r)}{flag}",
                 band_text(r), verdict(r), f"{r['wall_s']:.1f}", f"{r['cpu_s']:.1f}", r["commit"]]
        if changed is not None:
            cells.append(changed.get(r["commit"], "unknown"))
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(lines)


def std_text(r):
    if r.get("std") is None:
        return ""
    return f" ± {fmt_std(r, r['std'])}" + ("" if r.get("error_kind") == "absolute" else " %")


def headline_table(ledger):
    """The headline figures of cases.HEADLINE: per figure its record at the listed N (full tier)."""
    recs = {(r["case"], r["N"]): r for r in ledger["records"] if r["tier"] == "full"}
    lines = ["| figure | N | error (mean ± std) | band | verdict | traceable |", "|---|---|---|---|---|---|"]
    for fid, n in case_table.HEADLINE:
        r = recs.get((fid, n))
        if r is None:
            lines.append(f"| {fid} | {n} | not run | | | |")
            continue
        trace = "legacy: no run file" if r.get("legacy") else ("provisional" if r.get("provisional") else "run file")
        lines.append(f"| {fid} | {n} | {fmt_err(r, r.get('error'))}{std_text(r)} | {band_text(r)} | {verdict(r)} | "
                     f"{trace} |")
    return "\n".join(lines)


def commits_table(ledger):
    """Which binaries made the records: per commit (a "+dirty" suffix: a dirty tree), tiers, counts, dates."""
    by = {}
    for r in ledger["records"]:
        by.setdefault(r["commit"], []).append(r)
    lines = ["| commit | clean | tiers | records | legacy | first date | last date |", "|---|---|---|---|---|---|---|"]
    for c, rs in sorted(by.items(), key=lambda kv: min(r["date"] for r in kv[1])):
        clean = "no" if "+dirty" in c or any(r.get("clean") is False for r in rs) else "yes"
        lines.append(f"| {c} | {clean} | {', '.join(sorted({r['tier'] for r in rs}))} | {len(rs)} | "
                     f"{sum(1 for r in rs if r.get('legacy'))} | {min(r['date'] for r in rs)[:10]} | "
                     f"{max(r['date'] for r in rs)[:10]} |")
    return "\n".join(lines)


def ledger_counts(ledger):
    return rules.counts(ledger["records"])


def changed_since(ledger):
    """{commit: whether engine/ or physics/ changed since it} for the records' commits."""
    return {c: rules.code_changed_since(c) for c in {r["commit"] for r in ledger["records"]}}


def write_markdown(ledger, path):
    c = ledger_counts(ledger)
    ch = changed_since(ledger)
    parts = ["# Validation ledger", "",
             "Generated by `python3 -m tools.validate report` from `ledger.json`; do not edit by hand. Schema and rules: "
             "README.md in this directory.", "",
             f"Validation records (full tier, traceable): {c['validation_records']}: {c['pass']} pass, {c['miss']} "
             f"miss, {c['tuned']} tuned after seeing (never a pass), {c['failed']} failed. Apart: "
             f"{c['calibration_records']} calibration and {c['construction_records']} construction records (not "
             f"judged), {c['study_records']} study records (scan variants: reported, never judged), "
             f"{c['regression_records']} regression records (fast tier), {c['provisional_records']} "
             f"provisional and {c['legacy_records']} legacy records (no run file: not counted).", "",
             "## Full tier (validations against a paper, a closed form or a reference tool)", "",
             ledger_table(ledger, "validation", ch), "",
             "## Calibration residuals and figures true by construction (reported, never judged)", "",
             ledger_table(ledger, "calibration", ch), "",
             "## Studies (scan variants and readings of numerics the paper does not give: reported beside the "
             "validations, never judged, left out of the headline table)", "",
             ledger_table(ledger, "study", ch), "",
             "## Fast tier (regression guards; bands from measured scatter: inside or outside, never a pass)", "",
             ledger_table(ledger, "regression", ch), "",
             "## Provisional records (from a dirty tree; never counted)", "",
             ledger_table(ledger, "provisional", ch), "",
             "## Legacy records (made before run files were kept: cannot be recomputed; never counted)", "",
             ledger_table(ledger, "legacy", ch), "",
             "## Which binaries made the records", "", commits_table(ledger), "",
             "## Sources, calibrations and marks", ""]
    parts += sources_section(ledger)
    if ledger.get("perf"):
        parts += ["", "## Perf (speed and memory; `python3 -m tools.perf report` makes them from the perf cases' result "
                  "files, benchmarks/perf/)", "", rules.perf_table(ledger, full=True)]
    if ledger.get("rebases"):
        parts += ["", "## Rebases (new first config values after a documented model change)", ""]
        for b in ledger["rebases"]:
            parts.append(f"- **{b['case']}** ({b['date']}, {b['commit']}; {len(b['changed'])} config keys"
                         f"{'; decided after seeing: marked tuned' if b.get('seen') else ''}): {b['why']}")
    for b in ledger.get("removed", []):
        parts.append(f"- removed record **{b['case']}** N={b['N']} ({b['tier']}, {b['date']}): {b['why']}")
    parts += extras_section(ledger)
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(parts) + "\n")
    os.replace(tmp, path)


def sources_section(ledger):
    parts, seen = [], set()
    for r in ledger["records"]:
        if r["case"] in seen:
            continue
        seen.add(r["case"])
        parts.append(f"- **{r['case']}**: {r['source']}. Reference: {r['reference_origin']}. "
                     f"Calibrated on: {r['calibrated_on'] or 'nothing'}.")
        for t in r.get("tuned_after_seeing", []):
            parts.append(f"  - tuned after seeing: `{t['parameter']}`: {t['why']}")
        for v in r.get("variants", []):
            parts.append(f"  - variant: {v}")
        if r.get("null_reason"):
            parts.append(f"  - not evaluated: {r['null_reason']}")
    return parts


def extras_section(ledger):
    extras = [r for r in ledger["records"] if r.get("extra")]
    if not extras:
        return []
    parts = ["", "## Side figures and variants per record (mean over the runs)", "",
             "| case | tier | N | figure | mean | per run |", "|---|---|---|---|---|---|"]
    for r in extras:
        for k, xs in sorted(r["extra"].items()):
            nums = [x for x in xs if isinstance(x, (int, float)) and x is not None and math.isfinite(x)]
            if not nums:
                continue
            parts.append(f"| {r['case']} | {r['tier']} | {r['N']} | {k} | {statistics.fmean(nums):.6g} | "
                         + ", ".join(f"{x:.6g}" for x in nums) + " |")
    return parts


def cmd_report(a):
    write_reports(load_ledger(a.ledger), os.path.dirname(os.path.abspath(a.ledger)))
    print(json.dumps(ledger_counts(load_ledger(a.ledger))))
    return 0


def cmd_check_hashes(a):
    ledger = load_ledger(a.ledger)
    by_id = {f.id: c for c in case_table.CASES for f in c.figures}
    bad = []
    for r in ledger["records"]:
        c = by_id.get(r["case"])
        if c is None:
            bad.append(f"{r['case']}: in the ledger but not in benchmarks/validation/cases.py")
            continue
        now = config_hashes(c)
        for f, h in sorted(r["configs"].items()):
            if now.get(f) != h:
                bad.append(f"{r['case']} N={r['N']} ({r['tier']}): {f} changed since the record of {r['commit']} "
                           f"({h} -> {now.get(f, 'missing')}); rerun: python3 -m tools.validate run --tier {r['tier']} "
                           f"--case {r['case']} --sizes {r['N']}")
        for f in sorted(set(now) - set(r["configs"])):
            bad.append(f"{r['case']} N={r['N']} ({r['tier']}): uses {f}, not in its record; rerun it")
    for line in bad:
        print(line, file=sys.stderr)
    print(f"check-hashes: {len(ledger['records'])} records, {len(bad)} stale")
    return 1 if bad else 0


def cmd_derive_bands(a):
    """Runs the fast tier of the cases at the given seeds and writes mean ± k std of each figure's
    error to fast_bands.json (with the derivation), the regression band of the fast tier."""
    runner = Runner(a.sparkdem, a.build, a.threads, a.reuse)
    bands = load_json(FAST_BANDS) if os.path.exists(FAST_BANDS) else {}
    for c in selected(a.case, "fast"):
        for n in c.tiers["fast"]["sizes"]:
            with futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
                runs = list(pool.map(lambda s: run_one(runner, c, "fast", n, s, a.workdir), a.seeds))
            for r in runs:
                if r["error"]:
                    print(f"  seed {r['seed']}: {r['error']}", file=sys.stderr)
            for fig in c.figures:
                st = ensemble(runs, fig.key, fig.absolute)
                if st is None or st["count"] < 3:
                    print(f"  {fig.id} N={n}: fewer than 3 runs, no band", file=sys.stderr)
                    continue
                half = max(a.k * st["std"], a.floor)
                bands[f"{fig.id}@N{n}"] = {
                    "center": st["error"], "halfwidth": half,
                    "derivation": f"mean ± max({a.k:g} std, {100 * a.floor:g} %) of the relative error over seeds "
                                  f"{[r['seed'] for r in runs]} at N = {n} ({100 * st['error']:+.3f} ± "
                                  f"{100 * st['std']:.3f} %), binary of commit {runner.commit}"
                                  f"{'' if runner.clean else ' (dirty tree)'}, {time.strftime('%Y-%m-%d')}",
                    "per_seed": [p["error"] for p in st["per_seed"]]}
                print(f"  {fig.id} N={n}: {bands[f'{fig.id}@N{n}']['derivation']}")
    write_json_atomic(FAST_BANDS, dict(sorted(bands.items())))
    return 0


# A generated table in a document: groups (opening marker, kind, table, closing marker).
TABLE_BLOCK = re.compile(r"(<!-- ledger:table (validation|calibration|study|regression|legacy|provisional|headline|commits|perf(?: [a-z_]+)?) -->\n)"
                         r"(.*?)(<!-- ledger:end -->)", re.S)


def cmd_check_docs(a):
    """Every figure quoted in FILE beside a ledger tag `[ledger: CASE N=n]` (or `[ledger: CASE N=n FIELD]`,
    FIELD error (default), measured, reference, std, wall_s) must equal the ledger's, to the digits printed;
    every generated block `<!-- ledger:table KIND -->...<!-- ledger:end -->` must equal the table."""
    ledger = load_ledger(a.ledger)
    recs = {(r["case"], r["N"], r["tier"]): r for r in ledger["records"]}
    bad, n_checked = [], 0
    tag = re.compile(r"([+\-−]?[0-9][0-9.,]*(?:e[+\-]?[0-9]+)?)\s*(%|s|S/m|MS/m)?\s*\[ledger: ([^\]\s]+) N=([0-9]+)"
                     r"(?: (fast|full))?(?: ([a-z_]+))?\]")
    for path in a.files:
        text = open(path).read()
        for m in tag.finditer(text):
            n_checked += 1
            num, unit, case, n, tier, field = m.groups()
            rec = recs.get((case, int(n), tier or "full"))
            where = f"{path}:{text[:m.start()].count(chr(10)) + 1}"
            if rec is None:
                bad.append(f"{where}: {case} N={n} {tier or 'full'} is not in the ledger")
                continue
            field = field or "error"
            val = rec.get(field)
            if val is None:
                bad.append(f"{where}: the ledger's {case} N={n} has no {field}")
                continue
            q = float(num.replace("−", "-").replace(",", ""))
            if unit == "%":
                val = 100 * val
            elif unit == "MS/m":
                val = val / 1e6
            digits = len(num.split(".")[1]) if "." in num else 0
            if abs(q - val) > 0.51 * 10 ** (-digits) + 1e-12:
                bad.append(f"{where}: quotes {num}{unit or ''} for {case} N={n} {field}; the ledger holds {val:.6g}")
        for m in TABLE_BLOCK.finditer(text):
            n_checked += 1
            if m.group(3).strip() != ledger_table(ledger, m.group(2)).strip():
                bad.append(f"{path}: the generated {m.group(2)} table differs from the ledger "
                           f"(regenerate: python3 -m tools.validate update-docs {path})")
    for line in bad:
        print(line, file=sys.stderr)
    print(f"check-docs: {n_checked} quoted figures and tables checked, {len(bad)} wrong")
    return 1 if bad else 0


def cmd_update_docs(a):
    """Rewrites every generated ledger table of FILE from the ledger."""
    ledger = load_ledger(a.ledger)
    for path in a.files:
        text = open(path).read()
        new = TABLE_BLOCK.sub(lambda m: m.group(1) + ledger_table(ledger, m.group(2)) + "\n" + m.group(4), text)
        if new != text:
            with open(path + ".tmp", "w") as f:
                f.write(new)
            os.replace(path + ".tmp", path)
            print(f"update-docs: {path} rewritten")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)

    def common(p, runs=True):
        p.add_argument("--ledger", default=LEDGER)
        if runs:
            p.add_argument("--case", nargs="*", default=[])
            p.add_argument("--sparkdem", default=os.environ.get("SPARKDEM_BIN", os.path.join(REPO, "build", "sparkdem")))
            p.add_argument("--build", default=os.path.join(REPO, "build"))
            p.add_argument("--workdir", default=os.path.join(REPO, "build", "validation"))
            p.add_argument("--threads", type=int, default=1)
            p.add_argument("--jobs", type=int, default=1)
            p.add_argument("--reuse", action="store_true")
    p = sub.add_parser("list")
    p.add_argument("--ids", choices=["fast", "full"], help="print only the case ids of this tier")
    p.set_defaults(fn=cmd_list)
    p = sub.add_parser("run")
    common(p)
    p.add_argument("--tier", choices=["fast", "full"], required=True)
    p.add_argument("--sizes", nargs="*", type=int, default=[])
    p.add_argument("--seeds", nargs="*", type=int, default=[])
    p.add_argument("--no-record", action="store_true", help="write nothing to the ledger")
    p.add_argument("--provisional", action="store_true",
                   help="record from a binary of a dirty tree: records marked provisional, never counted")
    p.add_argument("--no-report", action="store_true", help="record, but do not redraw ledger.md and the plot")
    p.add_argument("--strict", action="store_true", help="exit 1 when a figure leaves its band")
    p.set_defaults(fn=cmd_run)
    p = sub.add_parser("report")
    common(p, runs=False)
    p.set_defaults(fn=cmd_report)
    p = sub.add_parser("recompute", help="rebuild every record from its run file and compare with the ledger")
    common(p, runs=False)
    p.add_argument("--write", action="store_true", help="store the recomputed records")
    p.set_defaults(fn=cmd_recompute)
    p = sub.add_parser("check-ledger", help="fail on a dirty record, a cleared mark, a NaN, a missing run file")
    common(p, runs=False)
    p.add_argument("--no-head", action="store_true", help="do not compare the marks with the committed ledger")
    p.set_defaults(fn=cmd_check_ledger)
    p = sub.add_parser("rebase", help="new first config values of cases after a documented model change")
    common(p, runs=False)
    p.add_argument("--case", nargs="+", required=True)
    p.add_argument("--why", required=True)
    p.add_argument("--seen", action="store_true",
                   help="the change was decided after seeing a figure of the case: its figures are marked tuned")
    p.set_defaults(fn=cmd_rebase)
    p = sub.add_parser("check-hashes")
    common(p, runs=False)
    p.set_defaults(fn=cmd_check_hashes)
    for name, fn in (("check-docs", cmd_check_docs), ("update-docs", cmd_update_docs)):
        p = sub.add_parser(name)
        common(p, runs=False)
        p.add_argument("files", nargs="+")
        p.set_defaults(fn=fn)
    p = sub.add_parser("derive-bands")
    common(p)
    p.add_argument("--seeds", nargs="+", type=int, required=True)
    p.add_argument("--k", type=float, default=3.0)
    p.add_argument("--floor", type=float, default=0.0, help="smallest half-width (relative) of a band")
    p.set_defaults(fn=cmd_derive_bands)
    a = ap.parse_args(argv)
    try:
        return a.fn(a)
    except (RuntimeError, OSError, KeyError, ValueError) as e:
        print(f"validate: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
