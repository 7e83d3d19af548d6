"""The plumbing every performance case shares (tools/perf.py runs the cases of benchmarks/perf/cases.py).

One place for what the benchmark scripts used to repeat each: the sparkdem binary and the build
directory, thread and wait-policy settings, writing a scene, launching sparkdem or a peer code
(timed: wall and the child's own CPU time and peak RSS, with the load average before and after),
interleaving variants over repeats, medians with min and max, the machine's facts (load, cores,
commit, versions) and atomic CSV/JSON writes (temporary name, then os.replace).
"""
import csv
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

from tools.ledger import binary_build, write_json_atomic

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
__all__ = ["REPO", "Context", "study_parser", "print_means", "run_study_scene", "write_csv_atomic", "write_json_atomic", "stats", "interleave", "load_config",
           "lammps_version", "git", "git_head", "git_history_unavailable", "cpu_model", "machine", "machine_label"]


# ---------------------------------------------------------------- files and numbers

def study_parser(doc, n_default, csv_default, seeds_default="1,2,3"):
    """The arguments every ensemble study over N and packing seeds takes: --sparkdem, --workdir,
    --n (comma list), --seeds (comma list), --csv (its output, `csv_default` in the repository)."""
    import argparse
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--sparkdem", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--n", default=n_default)
    ap.add_argument("--seeds", default=seeds_default)
    ap.add_argument("--csv", default=os.path.join(REPO, csv_default))
    return ap


def run_study_scene(sparkdem, workdir, tag, scene, threads=1, reuse=False):
    """Writes `scene` (a dict) to WORKDIR/TAG.json, runs `sparkdem run` on it into WORKDIR/TAG with
    `threads` OpenMP threads (a failed run raises), and returns (that directory, its summary.json).
    With reuse, a finished run of the same scene already in WORKDIR/TAG is returned instead."""
    path = os.path.join(workdir, tag + ".json")
    out = os.path.join(workdir, tag)
    if reuse and os.path.exists(os.path.join(out, "summary.json")) and os.path.exists(path):
        with open(path) as f:
            if json.load(f) == json.loads(json.dumps(scene)):
                with open(os.path.join(out, "summary.json")) as g:
                    return out, json.load(g)
    with open(path, "w") as f:
        json.dump(scene, f)
    subprocess.run([sparkdem, "run", path, "-o", out, "--threads", str(threads), "--quiet"], check=True,
                   env=dict(os.environ, OMP_NUM_THREADS=str(threads)))
    with open(os.path.join(out, "summary.json")) as f:
        return out, json.load(f)


def print_means(rows, by, keys):
    """One line per distinct value of the columns `by` (in first-seen order): mean +- std over the
    rows sharing it of each column in `keys`."""
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r[b] for b in by), []).append(r)
    for g, sel in groups.items():
        line = [" ".join(f"{b}={v}" for b, v in zip(by, g))]
        for k in keys:
            v = [r[k] for r in sel]
            line.append(f"{k}={statistics.mean(v):.4f}+-{statistics.stdev(v) if len(v) > 1 else 0:.4f}")
        print(" ".join(line))


def write_csv_atomic(path, rows, fields=None):
    """rows (dicts) as CSV, header `fields` (default: the first row's keys), temporary name then rename."""
    if not rows:
        raise RuntimeError(f"no rows to write to {path}")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields or list(rows[0]), extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def stats(values):
    """{median, min, max, n} of a list of numbers."""
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "n": len(values)}


def interleave(variants, repeats, fn, log=print):
    """Runs fn(variant, repeat) for every variant once per round, `repeats` rounds (so slow drifts of
    the machine's load hit every variant alike); returns {variant: [results in round order]}."""
    out = {v: [] for v in variants}
    for rep in range(repeats):
        for v in variants:
            log(f"  round {rep + 1}/{repeats}: {v}")
            out[v].append(fn(v, rep))
    return out


def load_config(rel):
    """A config of the repository as a dict with its $include paths made absolute (so a copy runs
    from any directory)."""
    path = os.path.join(REPO, rel)
    with open(path) as f:
        c = json.load(f)

    def walk(x):
        if isinstance(x, dict):
            if isinstance(x.get("$include"), str) and not os.path.isabs(x["$include"]):
                x["$include"] = os.path.normpath(os.path.join(os.path.dirname(path), x["$include"]))
            for v in x.values():
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)
    walk(c)
    return c


# ---------------------------------------------------------------- the machine

def git(*args):
    """`git -C REPO ARGS...`'s stripped stdout, or "" when git is not installed (a bare CI root)."""
    try:
        out = subprocess.run(["git", "-C", REPO, *args], capture_output=True, text=True)
    except OSError:
        return ""
    return out.stdout.strip()


def git_head():
    return git("rev-parse", "--short=12", "HEAD") or "unknown"


def git_history_unavailable():
    """True on a shallow clone or without git: the commit that last changed a file cannot be named."""
    return git("rev-parse", "--is-shallow-repository") != "false"


def lammps_version(lmp="lmp"):
    """'29 Sep 2021 - Update 2 Compiler: ...' from `lmp -h`, or None without LAMMPS."""
    if not shutil.which(lmp):
        return None
    out = subprocess.run([lmp, "-h"], capture_output=True, text=True).stdout.splitlines()
    version = next((l.split(" - ", 1)[1].strip() for l in out if l.startswith("Large-scale Atomic") and " - " in l),
                   "unknown")
    compiler = next((l.strip() for l in out if "Compiler:" in l), "")
    return f"{version} {compiler}".strip()


def cpu_model(cpuinfo="/proc/cpuinfo"):
    """The CPU's "model name" from /proc/cpuinfo (its first processor), or "unknown CPU" where the
    file has none (another OS, some ARM kernels)."""
    try:
        with open(cpuinfo) as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and value.strip():
                    return " ".join(value.split())
    except OSError:
        pass
    return "unknown CPU"


def machine():
    """What a reader needs to judge a timing: the CPU model and cores (together the machine a record
    is compared within: machine_label), load averages, kernel, Python."""
    return {"cpu_model": cpu_model(), "cores": os.cpu_count(), "load_average": list(os.getloadavg()),
            "uname": " ".join(os.uname()[2:5]), "python": ".".join(map(str, sys.version_info[:3]))}


def machine_label(m):
    """"CPU model, N cores" of a sidecar's machine dict; None for a sidecar written before the harness
    stored the CPU model (an unknown machine: the perf guard compares nothing with its records)."""
    if not m or not m.get("cpu_model"):
        return None
    return f"{m['cpu_model']}, {m.get('cores', '?')} cores"


# ---------------------------------------------------------------- running

class Context:
    """What a case's run function gets: its work directory, the binaries, the options of the run
    (repeats, threads, quick) and the launchers. Every launch is logged in self.launches (command,
    rc, wall, CPU, peak RSS, load before and after)."""

    def __init__(self, case, workdir, sparkdem, build, repeats, threads, quick, log=print):
        self.case, self.workdir, self.build, self.quick, self.log = case, workdir, build, quick, log
        self.sparkdem = os.path.abspath(sparkdem)
        if not os.access(self.sparkdem, os.X_OK):
            raise RuntimeError(f"{self.sparkdem} is not an executable sparkdem (give --sparkdem PATH)")
        self.repeats = repeats or case.repeats
        self.threads = threads or case.threads
        self.ranks_list = case.ranks
        self.scenes = []  # the case mechanics: --scenes (empty: every scene)
        self.launches = []
        os.makedirs(workdir, exist_ok=True)

    def path(self, *parts):
        return os.path.join(self.workdir, *parts)

    def tool(self, rel):
        """A benchmark executable of the build directory (e.g. benchmarks/electric_solvers/bench_electric)."""
        p = os.path.join(self.build, rel)
        if not os.access(p, os.X_OK):
            raise RuntimeError(f"{p} not found: build it (ninja -C {self.build} {os.path.basename(rel)}_exe)")
        return p

    def need(self, program, package):
        p = shutil.which(program)
        if not p:
            raise RuntimeError(f"{program} not on PATH (Debian package {package})")
        return p

    def write_scene(self, scene, name):
        """Writes a scene dict to the work directory; returns its path."""
        path = self.path(name + ".json")
        with open(path + ".tmp", "w") as f:
            json.dump(scene, f, indent=1)
        os.replace(path + ".tmp", path)
        return path

    def launch(self, cmd, name, threads=1, policy="passive", env=None, cwd=None, sample_rss=False, stdout=None):
        """Runs cmd (its output to NAME.log, or `stdout`, and NAME.err in the work directory) with OMP_NUM_THREADS =
        threads and OMP_WAIT_POLICY = policy (None: the runtime's default); returns its meta dict:
        rc, wall_s, cpu_s (the child's own, os.wait4), load before/after and, with sample_rss,
        max_rss_kb and the line of run.log current when the sampled VmRSS peaked. The peak RSS is
        GNU time's (%M): a child forked from this Python would inherit its resident set in
        ru_maxrss. Raises on rc != 0."""
        e = dict(os.environ, OMP_NUM_THREADS=str(threads))
        e.pop("OMP_WAIT_POLICY", None)
        e.pop("SPARKDEM_PARALLEL_MIN_ITEMS", None)
        if policy:
            e["OMP_WAIT_POLICY"] = policy.upper()
        e.update(env or {})
        rss_file = self.path(name + ".maxrss")
        run = ["/usr/bin/time", "-f", "%M", "-o", rss_file] + cmd if sample_rss else cmd
        load0, t0 = os.getloadavg()[0], time.monotonic()
        with open(stdout or self.path(name + ".log"), "w") as out, open(self.path(name + ".err"), "w") as err:
            p = subprocess.Popen(run, stdout=out, stderr=err, env=e, cwd=cwd or self.workdir)
            status, usage, peak_at = self._wait(p, sample_rss and self._run_log(cmd))
        meta = {"name": name, "command": " ".join(cmd), "rc": os.waitstatus_to_exitcode(status),
                "wall_s": time.monotonic() - t0, "cpu_s": usage.ru_utime + usage.ru_stime,
                "load_before": load0, "load_after": os.getloadavg()[0], "threads": threads,
                "wait_policy": policy or "default"}
        if sample_rss:
            meta.update(max_rss_kb=int(open(rss_file).read().split()[-1]), peak_during=peak_at)
        self.launches.append(meta)
        if meta["rc"] != 0:
            raise RuntimeError(f"{cmd[0]} exited with {meta['rc']}: see {self.path(name + '.err')}")
        return meta

    @staticmethod
    def _run_log(cmd):
        return os.path.join(cmd[cmd.index("-o") + 1], "run.log") if "-o" in cmd else None

    @staticmethod
    def _wait(p, log):
        """os.wait4 of the child (its own rusage); with `log`, the VmRSS of its child (the command
        under GNU time) sampled every 0.2 s, and the line of `log` current at its highest."""
        if not log:
            _, status, usage = os.wait4(p.pid, 0)
            return status, usage, ""
        best, where = 0, ""
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                return status, usage, where
            try:
                kid = open(f"/proc/{p.pid}/task/{p.pid}/children").read().split()[0]
                rss = next(int(l.split()[1]) for l in open(f"/proc/{kid}/status") if l.startswith("VmRSS:"))
                if rss > best:
                    best, where = rss, (open(log).read().splitlines() or [""])[-1].strip() if os.path.exists(log) else ""
            except (OSError, StopIteration, IndexError):
                pass
            time.sleep(0.2)

    def sparkdem_run(self, scene, name, threads=1, policy="passive", env=None, ranks=1, sample_rss=False):
        """Runs `sparkdem run SCENE -o NAME_out --threads T --quiet` (under `mpirun -np RANKS` for
        ranks > 1); scene: a dict (written as NAME.json) or a path. Returns (out dir, meta)."""
        path = self.write_scene(scene, name) if isinstance(scene, dict) else scene
        out = self.path(name + "_out")
        shutil.rmtree(out, ignore_errors=True)
        cmd = [self.sparkdem, "run", path, "-o", out, "--threads", str(threads), "--quiet"]
        if ranks > 1:
            cmd = [self.need("mpirun", "openmpi-bin"), "--allow-run-as-root", "--oversubscribe", "-np", str(ranks)] + cmd
        return out, self.launch(cmd, name, threads, policy, env, sample_rss=sample_rss)

    def summary(self, out):
        with open(os.path.join(out, "summary.json")) as f:
            return json.load(f)

    def versions(self, peers=()):
        """sparkdem's commit and tree state (from --version) and each peer's version."""
        commit, clean = binary_build(self.sparkdem)
        v = {"sparkdem": commit + ("" if clean else "+dirty"), "repository_head": git_head()}
        if "lammps" in peers:
            v["lammps"] = lammps_version()
        return v


def steps_patched_lammps(src, dst, steps):
    """A copy of a LAMMPS input with only the number of its `run` command changed."""
    text = open(src).read()
    new, n = re.subn(r"(?m)^run\s+\d+\s*$", f"run {steps}", text)
    if n != 1:
        raise RuntimeError(f"{src}: expected one `run N` line, found {n}")
    with open(dst, "w") as f:
        f.write(new)
    return dst
