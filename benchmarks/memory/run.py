#!/usr/bin/env python3
"""Peak memory per particle (issue 23 item 6): bytes per particle net of the executable.

usage: benchmarks/memory/run.py [--sparkdem build/sparkdem] [--scenes pour,sps_nial] [--out benchmarks/memory/results.csv]

For each scene: runs `sparkdem run configs/<scene>.json` on one thread and samples the process's
VmRSS every 0.2 s (with the run.log line current at that moment, to locate the peak); the peak is
the kernel's maximum resident set size of the process (ru_maxrss); the baseline is that of
`sparkdem --version` (the executable and its shared libraries; `sparkdem check` would also count
the particles a lattice generator makes while checking). Net bytes per particle = (peak - baseline) / particles, with particles the
largest count in summary.json. Writes one CSV row per scene and prints it.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def vmrss_kb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def last_log_line(path):
    try:
        with open(path) as f:
            lines = f.readlines()
        return lines[-1].strip() if lines else ""
    except OSError:
        return ""


def peak_of(cmd, log=None):
    """Peak RSS [kB] of the command: the kernel's ru_maxrss of the child (os.wait4); the run.log
    line current when the sampled VmRSS (every 0.2 s) was highest locates it."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    t0 = time.time()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    sampled, where = 0, ""
    while True:
        pid, status, usage = os.wait4(p.pid, os.WNOHANG)
        if pid:
            break
        r = vmrss_kb(p.pid)
        if r and r > sampled:
            sampled, where = r, (last_log_line(log) if log else "")
        time.sleep(0.2)
    return usage.ru_maxrss, where, time.time() - t0, os.waitstatus_to_exitcode(status)


def particles_of(out):
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    return max([st.get("particles") or 0 for st in s.get("stages", [])] + [0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    ap.add_argument("--scenes", default="pour,sps_nial")
    ap.add_argument("--out", default=os.path.join(REPO, "benchmarks", "memory", "results.csv"))
    a = ap.parse_args()
    rows = []
    for scene in a.scenes.split(","):
        cfg = os.path.join(REPO, "configs", scene + ".json")
        base, _, _, rc0 = peak_of([a.sparkdem, "--version"])
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "out")
            peak, where, wall, rc = peak_of([a.sparkdem, "run", cfg, "-o", out, "--threads", "1", "--quiet"],
                                            os.path.join(out, "run.log"))
            n = particles_of(out) if rc == 0 else 0
        row = {"scene": scene, "particles": n, "peak_rss_kb": peak, "baseline_rss_kb": base,
               "net_bytes_per_particle": round((peak - base) * 1024 / n) if n else "", "wall_s": round(wall, 1),
               "rc": rc, "peak_during": where}
        rows.append(row)
        print(row, flush=True)
    tmp = a.out + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
