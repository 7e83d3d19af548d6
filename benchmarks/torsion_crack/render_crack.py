#!/usr/bin/env python3
"""The pin at crack onset, rendered (issue 61): render_crack.png in this directory.

usage: python3 -m benchmarks.torsion_crack.render_crack [--sparkdem BUILD/sparkdem] [--workdir DIR]
           [--threads N] [--output PNG] [--reuse]

Runs configs/torsion_crack.json unchanged but for frames every FRAME_EVERY steps of the twist
stage, reads the resistance-rise onset twist (torsion_resistance_onset_twist, the 1 % rise the
ledger's seed001/torsion_onset_resistance case validates) from the last row of timeseries.csv,
takes the first frame whose time is at or after the first row at that twist, and renders it with
tools/render.py and configs/views/crack.json: the particles faint, coloured by potential, the
broken bonds as tubes coloured by the step they broke at. Prints the frame, its twist and the
broken bonds. Needs pvpython (python3-paraview) and, without a display, xvfb-run.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
FRAME_EVERY = 1000  # of about 68,000 twist steps: the onset frame within 1.5 % of the twist


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sparkdem", default=os.path.join(REPO, "build", "sparkdem"))
    ap.add_argument("--workdir", default=None, help="where the run goes (default: a temporary directory)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--output", default=os.path.join(HERE, "render_crack.png"))
    ap.add_argument("--reuse", action="store_true", help="render the run already in WORKDIR/out (with --workdir)")
    a = ap.parse_args()
    work = a.workdir or tempfile.mkdtemp(prefix="sparkdem_render_crack_")
    with open(os.path.join(REPO, "configs", "torsion_crack.json")) as f:
        scene = json.load(f)
    twist = next(s for s in scene["stages"] if s["name"] == "twist")
    twist.setdefault("output", {})["frame_every"] = FRAME_EVERY
    # the config's relative paths (includes, materials) resolve from configs/
    path = os.path.join(REPO, "configs", ".render_crack_scene.json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    out = os.path.join(work, "out")
    try:
        if not (a.reuse and os.path.isfile(os.path.join(out, "summary.json"))):
            # --report-only: the config's banded checks (the ledger's business) do not stop the picture
            subprocess.run([a.sparkdem, "run", path, "-o", out, "--quiet", "--report-only", "--threads", str(a.threads)], check=True)
    finally:
        os.remove(path)
    with open(os.path.join(out, "timeseries.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r.get("torsion_twist") not in (None, "", "nan")]
    onset = float(rows[-1]["torsion_resistance_onset_twist"])
    if not math.isfinite(onset):
        sys.exit("render_crack: the run reports no resistance-rise onset")
    t_onset = next(float(r["time"]) for r in rows if float(r["torsion_twist"]) >= onset)
    frames = subprocess.run([sys.executable, "-c", "import h5py, glob, sys\n"
                             "for f in sorted(glob.glob(sys.argv[1] + '/frames/*.h5')):\n"
                             "    h = h5py.File(f, 'r'); b = h['bonds/broken'][:].sum() if 'bonds' in h else 0\n"
                             "    s = h.attrs['stage']; s = s.decode() if isinstance(s, bytes) else s\n"
                             "    print(f, repr(float(h.attrs['time'])), s, int(b))", out],
                            capture_output=True, text=True, check=True).stdout.split("\n")
    frames = [l.split() for l in frames if l]
    index = next(k for k, (f, t, stage, b) in enumerate(frames) if stage == "twist" and float(t) >= t_onset)
    f, t, stage, broken = frames[index]
    print("render_crack: onset twist %.5f rad at t = %.6g s; frame %d (t = %s s): %s broken bonds" % (onset, t_onset, index, t, broken))
    subprocess.run([sys.executable, os.path.join(REPO, "tools", "render.py"), os.path.join(out, "results.xdmf"), "-o", a.output,
                    "--view", os.path.join(REPO, "configs", "views", "crack.json"), "--frame", str(index)], check=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
