#!/usr/bin/python3
"""Stable-step estimate against the bisected limit, before and after a change (issue 23 item 4).

Runs the stability cases of the test binary (`[stability]`: extreme M2 and stable step S1-S4),
which bisect the limit of each scene and print their figures to SPARKDEM_EXTREME_CSV, once with
the current binary and, when given, once with a binary built from an earlier commit; writes
benchmarks/stable_step/results.csv: scene, estimate_before_s, estimate_s, limit_s, the two ratios
and the steps a dt_fraction scene saves (1 - estimate_before / estimate).

    /usr/bin/python3 benchmarks/stable_step/run.py --tests build/tests/sparkdem_tests \
        [--before /path/to/old/sparkdem_tests --before-commit f2520d1]
"""
import argparse
import csv
import os
import subprocess
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def figures(binary, must_pass=True):
    """{scene: {figure: value}} from one run of the stability cases (an earlier binary's own
    checks may fail where the estimate was looser: its figures are still written)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "fig.csv"
        env = dict(os.environ, SPARKDEM_EXTREME_CSV=str(out), OMP_NUM_THREADS="1")
        subprocess.run([binary, "[stability]"], env=env, check=must_pass, stdout=subprocess.DEVNULL)
        table = {}
        with open(out) as f:
            for row in csv.reader(f):
                if len(row) < 3 or row[0] == "case":
                    continue
                table.setdefault(row[0], {})[row[1]] = float(row[2])
        return table


def git_head():
    return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True,
                          text=True, check=True).stdout.strip()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tests", required=True, help="sparkdem_tests of the code under test")
    ap.add_argument("--before", help="sparkdem_tests built from an earlier commit (same [stability] cases)")
    ap.add_argument("--before-commit", default="", help="that commit, recorded in the CSV")
    ap.add_argument("--out", default=str(HERE / "results.csv"))
    a = ap.parse_args()
    now = figures(a.tests)
    before = figures(a.before, must_pass=False) if a.before else {}
    rows = []
    for scene, f in now.items():
        if "limit by bisection" not in f:
            continue
        est, lim = f["stable-step estimate"], f["limit by bisection"]
        old = before.get(scene, {}).get("stable-step estimate", float("nan"))
        rows.append({"scene": scene, "estimate_before_s": f"{old:.6g}", "estimate_s": f"{est:.6g}",
                     "network_estimate_s": f"{f.get('network estimate (no a-priori step)', float('nan')):.6g}",
                     "limit_s": f"{lim:.6g}", "before_over_limit": f"{old / lim:.4f}",
                     "estimate_over_limit": f"{est / lim:.4f}", "steps_saved": f"{1.0 - old / est:.4f}",
                     "commit": git_head(), "before_commit": a.before_commit})
    with open(a.out + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(a.out + ".tmp", a.out)
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
