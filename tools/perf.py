#!/usr/bin/python3
"""sparkdem's performance runner: the twin of tools/validate.py for speed and memory.
Run from the repository root as `/usr/bin/python3 -m tools.perf CMD` (docs/running.md, "Python tools"):

    perf list                               the cases: scene, peers, threads, ranks, repeats, figures, result file
    perf run --case GLOB ... [--repeats N] [--threads T ...] [--scenes S ...] [--quick] [--sparkdem PATH] [--build DIR]
             [--workdir DIR] [--record]
    perf report [DOC ...]                   the ledger's perf section, ledger.md and the perf tables of DOC
                                            (default docs/performance.md) from the cases' result files
    perf check                              fail when the ledger's perf section is not what the result
                                            files give (a record typed or edited by hand; ctest perf_records)

The table of cases is benchmarks/perf/cases.py, the plumbing they share (launching, timing, load,
atomic writes) benchmarks/perf/harness.py. `run` runs each selected case in WORKDIR/CASE (default
build/perf/), sparkdem and its peers interleaved round by round, and writes the case's result file
there with a sidecar RESULT.meta.json: the load average before and after (and at every launch), the
commit and tree state of the binary, the peers' versions, the machine, the options. It prints the
records the result yields. Only with --record (never with --quick) does it copy the result file and
its sidecar over the committed ones under benchmarks/ and run `report`.

`report` rebuilds ledger["perf"] (benchmarks/validation/ledger.json) from every case's committed
result file: a file with a sidecar gives records of origin "harness" (with its load and versions),
one without (written by the scripts the harness replaced) records of origin "imported", with the
commit the file names or the last commit that changed it. Timings depend on the machine's load:
record on an idle machine and read the load column.

`run` also compares each figure with the case's committed record of the same id (times and memory:
lower is better) and prints SLOWER for one more than 10 % worse (issue 40 item 6; the load column
says whether the machine's load or the code changed). Every record names its machine (the CPU model
and core count of the sidecar, issue 63 item 4) and a figure is compared only with a record of the
same machine: a record of another machine, or one made before the harness stored the CPU model
(an unknown machine), is not compared, and a NOT COMPARED line says so. `report` groups the
records by machine.

Exit codes: 0 done; 1 a case failed; 2 bad arguments or set-up errors; 3 done, but a figure is more
than 10 % worse than its last record.
"""
import argparse
import fnmatch
import json
import os
import shutil
import sys
import time

from benchmarks.perf import cases as case_table
from benchmarks.perf import harness
from tools import ledger as rules
from tools import validate

REPO = harness.REPO
DOCS = [os.path.join(REPO, "docs", "performance.md"), os.path.join(REPO, "benchmarks", "README.md")]
# The script that wrote each committed result file before the harness existed (origin of imported records).
WRITTEN_BEFORE_BY = {"mechanics": "benchmarks/mechanics/run.py", "threads": "benchmarks/threads/run.py",
                     "memory": "benchmarks/memory/run.py", "sps_nial": "sparkdem run configs/sps_nial.json --threads 1",
                     "networks": "bench_electric (ninja bench_electric)",
                     "networks_ranks": "benchmarks/electric_solvers/run_spread.sh", "ranks": "benchmarks/ranks/run.py",
                     "stable_step": "benchmarks/stable_step/run.py"}


def selected(patterns):
    out = [c for c in case_table.CASES if not patterns or any(fnmatch.fnmatch(c.id, p) for p in patterns)]
    if not out:
        raise ValueError(f"no case matches {patterns} (see: python3 -m tools.perf list)")
    return out


def cmd_list(a):
    for c in case_table.CASES:
        path = os.path.join(REPO, c.result)
        since = case_table.last_commit(path) if os.path.exists(path) else "none yet"
        print(f"{c.id}\n  scene: {c.scene}\n  peers: {', '.join(c.peers) or 'none'}; threads {c.threads}; ranks "
              f"{c.ranks}; repeats {c.repeats}; needs: {', '.join(['sparkdem'] + c.needs)}\n  result: {c.result} "
              f"(last changed {since})")
        for fid, what in c.figures.items():
            print(f"  {fid}: {what}")
    return 0


RUN_KEYS = ("versions", "load_before", "load_after", "load_max", "finished", "repeats", "machine")


def scene_run(meta, scene):
    """The run that measured a scene's rows: the sidecar's own, or, for a scene kept from an earlier
    run by `--scenes`, that run's (meta["kept_runs"][scene])."""
    return meta.get("kept_runs", {}).get(scene) or meta


def kept_runs(case, scenes):
    """For `perf run --scenes`: the runs of the committed result's other scenes (their sidecar
    entries), so that their kept rows keep their own commit and load."""
    committed = os.path.join(REPO, case.result + ".meta.json")
    if not scenes or not os.path.exists(committed):
        return {}
    old = json.load(open(committed))
    names = {r.get("scene") for r in case.records(os.path.join(REPO, case.result))} - set(scenes) - {None}
    return {n: {k: scene_run(old, n)[k] for k in RUN_KEYS if k in scene_run(old, n)} for n in sorted(names)}


def records_of(case, path):
    """The case's perf records of a result file, with their origin, load, versions and machine
    (sidecar). A record gets a `machine` ("CPU model, N cores") only from a sidecar that names the CPU
    model (harness.machine_label): older records and imported ones have none (an unknown machine)."""
    meta_path = path + ".meta.json"
    meta = json.load(open(meta_path)) if os.path.exists(meta_path) else None
    recs = case.records(path)
    for r in recs:
        r["case"] = case.id
        r["source"] = os.path.relpath(path, REPO) if path.startswith(REPO) else path
        if meta:  # the commit is the measured binary's (a case's own commit column says the same)
            run = scene_run(meta, r.get("scene"))
            r.update({"origin": "harness", "commit": run["versions"]["sparkdem"],
                      "load_before": run["load_before"][0], "load_after": run["load_after"][0],
                      "load_max": run["load_max"], "versions": run["versions"], "measured_at": run["finished"]})
            r.setdefault("repeats", run["repeats"])
            label = harness.machine_label(run.get("machine"))
            if label:
                r["machine"] = label
        else:
            r["origin"] = f"imported (written by {WRITTEN_BEFORE_BY.get(case.id, 'an earlier script')})"
    return recs


# Units of record values where lower is better (times, memory): the ones the guard compares.
LOWER_IS_BETTER = {"s", "s/step", "B/particle"}
SLOWDOWN_LIMIT = 0.10  # issue 40 item 6: flag a figure more than 10 % worse than its last record


UNKNOWN_MACHINE = "unknown machine"


def guard(new, old, limit=SLOWDOWN_LIMIT):
    """The perf guard (issue 40 item 6; by machine since issue 63 item 4): (slower, not_compared).
    slower: the records of `new` more than `limit` worse than the record of the same id in `old` (the
    last committed ones) measured on the same machine, as (id, old value, new value, relative change,
    old commit). not_compared: (id, why) for the records that have an old record of the same id and
    unit but were not compared because either names no machine (UNKNOWN_MACHINE) or the machines
    differ: a record made on another machine is no baseline. A record of the same measurement as
    its old one (`measured_at`: a scene kept by `run --scenes`) is neither. Only values in
    LOWER_IS_BETTER units with a positive old value are compared."""
    last = {r["id"]: r for r in old}
    slower, not_compared = [], []
    for r in new:
        o = last.get(r["id"])
        if o is None or r.get("unit") not in LOWER_IS_BETTER or o.get("unit") != r.get("unit"):
            continue
        if r.get("measured_at") and r.get("measured_at") == o.get("measured_at"):
            continue  # the same measurement: a scene kept from the committed run by `run --scenes`
        m0, m1 = o.get("machine"), r.get("machine")
        if not m0 or not m1:
            which = "its record" if not m0 else "this run"
            not_compared.append((r["id"], f"{which} names no machine ({UNKNOWN_MACHINE})"))
            continue
        if m0 != m1:
            not_compared.append((r["id"], f"recorded on another machine ({m0}; this run: {m1})"))
            continue
        v0, v1 = o.get("value"), r.get("value")
        if not isinstance(v0, (int, float)) or not isinstance(v1, (int, float)) or not v0 > 0:
            continue
        change = v1 / v0 - 1.0
        if change > limit:
            slower.append((r["id"], v0, v1, change, o.get("commit", "")))
    return slower, not_compared


def slowdowns(new, old, limit=SLOWDOWN_LIMIT):
    """The `slower` list of guard(new, old, limit)."""
    return guard(new, old, limit)[0]


def run_case(case, a):
    workdir = os.path.join(os.path.abspath(a.workdir), case.id)
    ctx = harness.Context(case, workdir, a.sparkdem, os.path.abspath(a.build), a.repeats, a.threads, a.quick)
    ctx.result = os.path.join(workdir, os.path.basename(case.result))
    ctx.scenes = a.scenes
    load0, started = os.getloadavg(), time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    print(f"{case.id}: load average {load0[0]:.2f} on {os.cpu_count()} cores; work directory {workdir}", flush=True)
    case.run(ctx)
    load1 = os.getloadavg()
    meta = {"case": case.id, "quick": a.quick, "repeats": ctx.repeats, "threads": ctx.threads, "scenes": ctx.scenes,
            "kept_runs": kept_runs(case, ctx.scenes),
            "command": " ".join(["python3 -m tools.perf"] + sys.argv[1:]), "started": started,
            "finished": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()), "load_before": list(load0),
            "load_after": list(load1), "load_max": max([load0[0], load1[0]] + [m["load_after"] for m in ctx.launches]),
            "versions": ctx.versions(case.peers), "machine": harness.machine(), "launches": ctx.launches}
    harness.write_json_atomic(ctx.result + ".meta.json", meta)
    recs = records_of(case, ctx.result)
    for r in recs:
        share = r.get("thread_speedup_share")
        print(f"  {r['id']}: {rules.fmt_number(r.get('value'))} {r.get('unit', '')}  "
              f"ratio {rules.fmt_number(r.get('ratio'), 3)} ({r.get('ratio_of', '')})"
              + (f"; 2-thread speed-up {rules.fmt_number(share, 3)} of min(2, stream {r['stream_speedup']:.3f})"
                 if share is not None else ""))
    print(f"{case.id}: {len(recs)} records; load {load0[0]:.2f} -> {load1[0]:.2f} (max {meta['load_max']:.2f}); "
          f"wrote {ctx.result}", flush=True)
    if meta["load_max"] > (os.cpu_count() or 1):
        print(f"{case.id}: warning: the load average exceeded the core count: these timings are contaminated",
              file=sys.stderr)
    committed = os.path.join(REPO, case.result)
    slower, skipped = guard(recs, records_of(case, committed)) if os.path.exists(committed) else ([], [])
    for rid, why in skipped:
        print(f"  NOT COMPARED {rid}: {why}", file=sys.stderr)
    for rid, v0, v1, change, commit in slower:
        print(f"  SLOWER {rid}: {rules.fmt_number(v1)} against {rules.fmt_number(v0)} recorded at {commit} "
              f"({100 * change:+.1f} %, limit {100 * SLOWDOWN_LIMIT:.0f} %)", file=sys.stderr)
    return ctx.result, len(slower)


def cmd_run(a):
    if a.record and a.quick:
        raise ValueError("--quick results are smoke tests: they are never recorded")
    if a.scenes and any(c.id != "mechanics" for c in selected(a.case)):
        raise ValueError("--scenes applies to the case mechanics only")
    if a.record:  # records come from a binary built on a clean commit (as validate's refuse_dirty)
        commit, clean = rules.binary_build(a.sparkdem)
        if not clean:
            raise ValueError(f"refusing to record: {a.sparkdem} was built from commit {commit} with a dirty work tree "
                             f"(`sparkdem --version`). Commit, rebuild (cmake --build build), then run; or run without --record.")
    failed, slower = [], 0
    for case in selected(a.case):
        try:
            result, n_slower = run_case(case, a)
            slower += n_slower
        except (RuntimeError, OSError, KeyError, ValueError) as e:
            print(f"{case.id}: FAILED: {e}", file=sys.stderr)
            failed.append(case.id)
            continue
        if a.record:
            dest = os.path.join(REPO, case.result)
            for src, dst in ((result, dest), (result + ".meta.json", dest + ".meta.json")):
                shutil.copyfile(src, dst + ".tmp")
                os.replace(dst + ".tmp", dst)
            print(f"{case.id}: recorded {case.result}")
    if a.record and len(failed) < len(selected(a.case)):
        cmd_report(argparse.Namespace(ledger=a.ledger, files=[]))
    if failed:
        return 1
    return 3 if slower else 0


def committed_records():
    """The perf records of every case's committed result file."""
    recs = []
    for case in case_table.CASES:
        path = os.path.join(REPO, case.result)
        if not os.path.exists(path):
            print(f"perf: {case.result} not found: case {case.id} has no records", file=sys.stderr)
            continue
        recs += records_of(case, path)
    return recs


def cmd_check(a):
    """Every perf record of the ledger equals the one its result file gives, and no record is missing."""
    ledger = validate.load_ledger(a.ledger)
    want = {r["id"]: r for r in json.loads(json.dumps(rules.finite(committed_records())))}
    have = {r["id"]: r for r in ledger.get("perf", [])}
    if harness.git_history_unavailable():  # a shallow clone (or no git) cannot name the commit that last changed an imported file
        for r in list(want.values()) + list(have.values()):
            if r.get("origin", "").startswith("imported"):
                r.pop("commit", None)
    bad = [f"{i}: not made by any result file" for i in have if i not in want]
    bad += [f"{i}: missing from the ledger" for i in want if i not in have]
    bad += [f"{i}: differs from its result file ({want[i]['source']})" for i in want if i in have and have[i] != want[i]]
    for line in bad:
        print(line, file=sys.stderr)
    print(f"perf check: {len(have)} records, {len(bad)} wrong" + (" (python3 -m tools.perf report)" if bad else ""))
    return 1 if bad else 0


def cmd_report(a):
    """ledger["perf"] from the committed result files; ledger.md; the perf tables of the docs."""
    recs = committed_records()
    with validate.ledger_lock(a.ledger):
        ledger = validate.load_ledger(a.ledger)
        ledger["perf"] = recs
        rules.write_json_atomic(a.ledger, ledger)
    validate.write_reports(ledger, os.path.dirname(os.path.abspath(a.ledger)))
    print(f"perf: {len(recs)} records")
    for label, group in rules.perf_by_machine(recs):
        print(f"  {label}: {len(group)} records")
    return validate.cmd_update_docs(argparse.Namespace(ledger=a.ledger, files=a.files or DOCS))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list")
    p.set_defaults(fn=cmd_list)
    p = sub.add_parser("run")
    p.add_argument("--case", nargs="+", required=True, help="case ids or globs (python3 -m tools.perf list)")
    p.add_argument("--repeats", type=int, default=0, help="interleaved rounds (default: the case's)")
    p.add_argument("--threads", type=int, nargs="+", default=[],
                   help="the sparkdem thread counts of the case mechanics (default 1 2)")
    p.add_argument("--quick", action="store_true", help="the smallest scale that runs every step (never recorded)")
    p.add_argument("--scenes", nargs="+", default=[],
                   help="the case mechanics: run these scenes only; the other scenes' rows are kept from the committed result")
    p.add_argument("--sparkdem", default=os.environ.get("SPARKDEM_BIN", os.path.join(REPO, "build", "sparkdem")))
    p.add_argument("--build", default=os.path.join(REPO, "build"), help="build directory (benchmark executables)")
    p.add_argument("--workdir", default=os.path.join(REPO, "build", "perf"))
    p.add_argument("--ledger", default=validate.LEDGER)
    p.add_argument("--record", action="store_true",
                   help="copy the result over the committed one and regenerate the ledger's perf section and docs")
    p.set_defaults(fn=cmd_run)
    p = sub.add_parser("report")
    p.add_argument("--ledger", default=validate.LEDGER)
    p.add_argument("files", nargs="*", help="docs whose perf tables to rewrite (default docs/performance.md and benchmarks/README.md)")
    p.set_defaults(fn=cmd_report)
    p = sub.add_parser("check")
    p.add_argument("--ledger", default=validate.LEDGER)
    p.set_defaults(fn=cmd_check)
    a = ap.parse_args(argv)
    try:
        return a.fn(a)
    except (RuntimeError, OSError, KeyError, ValueError) as e:
        print(f"perf: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
