"""The rules of sparkdem's validation ledger (benchmarks/validation/README.md), apart from running.

tools/validate.py runs the cases and writes the records; this module holds what a reader's trust
rests on, as pure functions over the ledger's JSON:

- provenance: the commit a binary was built from and whether its tree was clean (`sparkdem
  --version`), and whether engine/ or physics/ changed since a record's commit;
- kinds and verdicts: `validation` (pass, miss, tuned, failed), `calibration` (the fitted run's
  residual), `construction` (true by construction: reported, never judged), `study` (a scan
  variant or a reading of numerics the source does not give: inside or outside its band, never a
  pass, not in the headline table), `regression` (fast tier: inside or outside its band, never a
  pass); a `provisional` record never counts;
- tuned marks: added, never removed (`tuned_marks` is append-only; every record of a figure carries
  every mark of that figure);
- the checks `python3 -m tools.validate check-ledger` runs: no record from a dirty tree unless provisional
  or legacy, no NaN, no cleared mark, one record per run and figure, a run file behind every record
  that is not legacy.
"""
import json
import math
import os
import re
import subprocess

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

KINDS = ("validation", "calibration", "construction", "regression", "study")
LEGACY_NOTE = ("made before run files were kept (issue 34, 2026-11-27): its runs are not in the repository, so its "
               "figures cannot be recomputed; rerun the case from a clean commit to make it traceable")


# ---------------------------------------------------------------- JSON without NaN

def finite(x):
    """x with every non-finite float (NaN, inf) replaced by None, recursively: ledger.json and run
    files are strict JSON (a figure that could not be evaluated is null with its reason)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite(v) for v in x]
    if hasattr(x, "item") and not isinstance(x, (str, bytes)):  # numpy scalars
        return finite(x.item())
    return x


def write_json_atomic(path, obj):
    """Strict JSON (allow_nan=False after `finite`), written to a temporary name and renamed."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        json.dump(finite(obj), f, indent=1, allow_nan=False)
        f.write("\n")
    os.replace(tmp, path)


def load_strict(path):
    """A JSON file that must hold no NaN/Infinity token (ValueError naming the token otherwise)."""
    def bad(tok):
        raise ValueError(f"{path}: holds the token {tok}, which is not JSON (write null with a reason)")
    with open(path) as f:
        return json.load(f, parse_constant=bad)


# ---------------------------------------------------------------- provenance

VERSION_RE = re.compile(r"commit ([0-9a-f]{7,40}|unknown) \((clean|dirty work tree)\)")


def binary_build(sparkdem):
    """(commit, clean) of a sparkdem binary from `sparkdem --version` (io/version/build_info.hpp): the
    commit it was built from (12 hex digits, or "unknown") and whether the work tree was clean."""
    out = subprocess.run([sparkdem, "--version"], capture_output=True, text=True).stdout
    m = VERSION_RE.search(out)
    if not m:
        return "unknown", False
    return m.group(1)[:12], m.group(2) == "clean"


def code_changed_since(commit, paths=("engine", "physics")):
    """"no" / "yes" / "unknown": whether `paths` differ between `commit` (a "+dirty" suffix is
    ignored) and the work tree's HEAD."""
    c = (commit or "").split("+")[0]
    if not re.fullmatch(r"[0-9a-f]{7,40}", c):
        return "unknown"
    try:
        rc = subprocess.run(["git", "-C", REPO, "diff", "--quiet", c, "HEAD", "--", *paths],
                            capture_output=True).returncode
    except OSError:
        return "unknown"
    return {0: "no", 1: "yes"}.get(rc, "unknown")


# ---------------------------------------------------------------- kinds and verdicts

def record_kind(fig, tier, n):
    """The kind of the record of figure `fig` (cases.Figure) in `tier` at size `n`."""
    if fig.kind == "construction":
        return "construction"
    if tier == "fast":
        return "regression"
    if n in fig.calibration_sizes:
        return "calibration"
    return fig.kind


def verdict(rec):
    """What a record says, by kind: validation pass/miss/tuned/failed; regression inside band /
    outside band; calibration residual; by construction; provisional and legacy records say so."""
    if rec.get("measured") is None:
        v = "failed"
    elif rec["kind"] == "validation":
        v = "pass" if rec.get("pass") else ("tuned" if rec.get("tuned_after_seeing") else "miss")
    elif rec["kind"] == "regression":
        v = "inside band" if rec.get("inside_band") else "outside band"
    elif rec["kind"] == "calibration":
        v = "calibration residual"
    elif rec["kind"] == "study":
        v = "study: " + ("inside band" if rec.get("inside_band") else "outside band")
    else:
        v = "by construction"
    if rec.get("provisional"):
        return "provisional, " + v
    return v


def counts(records):
    """The counts line: validation records only, provisional and legacy ones apart."""
    live = [r for r in records if not r.get("provisional") and not r.get("legacy")]
    val = [verdict(r) for r in live if r["kind"] == "validation"]
    return {"validation_records": len(val), "pass": val.count("pass"), "miss": val.count("miss"),
            "tuned": val.count("tuned"), "failed": val.count("failed"),
            "calibration_records": sum(1 for r in live if r["kind"] == "calibration"),
            "construction_records": sum(1 for r in live if r["kind"] == "construction"),
            "regression_records": sum(1 for r in live if r["kind"] == "regression"),
            "study_records": sum(1 for r in live if r["kind"] == "study"),
            "provisional_records": sum(1 for r in records if r.get("provisional")),
            "legacy_records": sum(1 for r in records if r.get("legacy"))}


# ---------------------------------------------------------------- tuned marks: added, never removed

SEEN_RE = re.compile(r"after seeing|after (?:one|a|two|three|\d+)\b[^.;]*?\bruns?\b|decided from (?:the|its) (?:figure|result)",
                     re.I)


def reason_says_seen(why):
    """True when a rebase's reason says the change was decided after seeing a figure of the case."""
    return bool(SEEN_RE.search(why or ""))


def add_marks(ledger, figure_id, marks):
    """Appends marks (dicts with parameter, why) to the figure's permanent list; returns how many were new."""
    have = ledger.setdefault("tuned_marks", {}).setdefault(figure_id, [])
    new = [m for m in marks if m not in have]
    have.extend(new)
    return len(new)


def with_marks(ledger, rec):
    """The record's tuned list united with every permanent mark of its figure (order kept)."""
    out = list(rec.get("tuned_after_seeing") or [])
    for m in ledger.get("tuned_marks", {}).get(rec["case"], []):
        if m not in out:
            out.append(m)
    return out


def carry_marks(ledger, rec):
    """Gives `rec` every permanent mark of its figure; a record so marked no longer passes."""
    rec["tuned_after_seeing"] = with_marks(ledger, rec)
    if rec.get("pass") and rec["tuned_after_seeing"]:
        rec["pass"] = False
    rec["verdict"] = verdict(rec)


# ---------------------------------------------------------------- the checks of check-ledger

def check_rules(ledger, head_ledger=None, ledger_dir="."):
    """Every broken rule of the ledger, as lines (empty: the ledger is sound). head_ledger: the
    committed ledger, whose permanent marks must all still be there; ledger_dir: where run_file
    paths start (the ledger's directory)."""
    bad = []
    recs = ledger.get("records", [])
    marks = ledger.get("tuned_marks", {})
    seen = {}
    for r in recs:
        key = (r["case"], r["tier"], r["N"])
        where = f"{r['case']} N={r['N']} ({r['tier']})"
        if key in seen:
            bad.append(f"{where}: two records of one case, tier and N")
        seen[key] = r
        if r.get("kind") not in KINDS:
            bad.append(f"{where}: kind {r.get('kind')!r} is not one of {', '.join(KINDS)}")
        dirty = "+dirty" in (r.get("commit") or "") or r.get("clean") is False
        if dirty and not r.get("provisional") and not r.get("legacy"):
            bad.append(f"{where}: recorded from a dirty tree ({r.get('commit')}) but not marked provisional")
        if not r.get("legacy") and not r.get("run_file"):
            bad.append(f"{where}: no run file (every record that is not legacy keeps its runs under runs/)")
        if r.get("run_file") and not os.path.exists(os.path.join(ledger_dir, r["run_file"])):
            bad.append(f"{where}: its run file {r['run_file']} is missing")
        for m in marks.get(r["case"], []):
            if m not in (r.get("tuned_after_seeing") or []):
                bad.append(f"{where}: the tuned mark on {m.get('parameter')} was cleared (marks are never removed)")
        if r.get("pass") and r["kind"] != "validation":
            bad.append(f"{where}: a {r['kind']} record carries pass (only validation records pass)")
        if r.get("pass") and (r.get("tuned_after_seeing") or r.get("provisional")):
            bad.append(f"{where}: passes although tuned or provisional")
    bad += duplicate_figures(recs)
    for fid, ms in (head_ledger or {}).get("tuned_marks", {}).items():
        for m in ms:
            if m not in marks.get(fid, []):
                bad.append(f"{fid}: the committed tuned mark on {m.get('parameter')} is gone from tuned_marks")
    return bad


def duplicate_figures(recs):
    """Two figures of one case, tier and N with identical values, references and band in every run: one
    run counted twice. One measured value judged against two references or two bands (a paper's own
    error beside the continuum's, a reproduce band beside a tighter one) is two comparisons; figures
    that equal each other by design list each other in `shares_values_with` (cases.py)."""
    bad, by_run, shares = [], {}, {}
    for r in recs:
        vals = tuple((p["seed"], p["measured"], p.get("reference")) for p in r.get("per_seed") or []
                     if p.get("measured") is not None)
        if vals:
            band = json.dumps(r.get("band"), sort_keys=True)
            by_run.setdefault((r["case"].split("/")[0], r["tier"], r["N"], vals, band), []).append(r["case"])
        shares[r["case"]] = set(r.get("shares_values_with") or [])
    for (src, tier, n, _, _), ids in by_run.items():
        declared = all(b in shares.get(a, set()) or a in shares.get(b, set()) for a in ids for b in ids if a < b)
        if len(ids) > 1 and not declared:
            bad.append(f"{', '.join(ids)} N={n} ({tier}): identical values in every run, one run counted twice")
    return bad


# ---------------------------------------------------------------- the perf section

def fmt_number(x, digits=4):
    if x is None:
        return ""
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def _load_text(r):
    """The load average a perf record was measured under: before/after the case's run (harness), or
    at its start (records imported from the scripts that came before the harness)."""
    if r.get("load_before") is not None:
        return f"{r['load_before']:.2f} / {r['load_after']:.2f}"
    return fmt_number(r.get("load_average"), 3)


UNKNOWN_MACHINE_NOTE = ("unknown (records made before the harness stored the CPU model, or imported: "
                        "the perf guard compares no figure with them)")


def perf_by_machine(recs):
    """[(label, records)] of perf records grouped by their `machine` ("CPU model, N cores"; issue 63
    item 4), machines in first-seen order, the records that name none last (UNKNOWN_MACHINE_NOTE)."""
    groups = {}
    for r in recs:
        groups.setdefault(r.get("machine") or "", []).append(r)
    out = [(m, g) for m, g in groups.items() if m]
    return out + ([(UNKNOWN_MACHINE_NOTE, groups[""])] if "" in groups else [])


def perf_table(ledger, full=True, case=None):
    """The perf records (tools/perf.py), all or those of one case, as one markdown table per machine
    (each under a line naming it: a figure compares only with figures of the same machine); without
    `full` (the docs), the thread records of scenes under 1e4 particles are left to ledger.md (unless
    the table is the threads case's own) and the origin column is left out."""
    cols = ["record", "particles / nodes", "threads", "value", "min / max", "ratio", "ratio of", "load", "commit"]
    cols += ["origin"] if full else []
    header = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    recs = []
    for r in ledger.get("perf", []):
        if case and r.get("case") != case:
            continue
        if not full and not case and r["id"].startswith("perf/threads/") and (r.get("particles") or 0) < 10000:
            continue
        recs.append(r)
    blocks = []
    for label, group in perf_by_machine(recs):
        lines = [f"Machine: {label}", ""] + header
        for r in group:
            spread = f"{fmt_number(r['min'])} / {fmt_number(r['max'])}" if r.get("min") is not None else ""
            value = f"{fmt_number(r.get('value'))} {r.get('unit', '')}"
            cells = [r["id"], fmt_number(r.get("particles")), fmt_number(r.get("threads")), value,
                     spread, fmt_number(r.get("ratio"), 3), r.get("ratio_of", ""), _load_text(r), r.get("commit", "")]
            cells += [r.get("origin", "")] if full else []
            lines.append("| " + " | ".join(str(c) for c in cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) if blocks else "\n".join(header)
