#!/usr/bin/env python3
"""tools/render.py on a small run (tests/scenario/data/joule_press_small.json, a lattice column
of ~100 spheres pressed between electrodes with an electrical network): writes a PNG of the
requested size whose pixels are not all the background, with particles coloured by potential and
the branches drawn as tubes coloured by |current|; a bad view file exits 2 naming the key.

    python3 tests/scenario/check_render.py --sparkdem BIN
Exit codes: 0 passed, 1 failed, 77 pvpython (or xvfb-run without a display) is missing.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SKIP = 77
# Counts the pixels that differ from the corner pixel (the background) of a PNG (runs in pvpython).
COUNT = """
import sys
from vtkmodules.vtkIOImage import vtkPNGReader
from vtkmodules.util.numpy_support import vtk_to_numpy
r = vtkPNGReader(); r.SetFileName(sys.argv[1]); r.Update()
img = r.GetOutput(); w, h, _ = img.GetDimensions()
a = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[:, :, :3].astype(int)
bg = a[0, 0]
print(w, h, int((abs(a - bg).sum(axis=2) > 30).sum()))
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sparkdem", required=True)
    a = ap.parse_args()
    if not shutil.which("pvpython") or (not os.environ.get("DISPLAY") and not shutil.which("xvfb-run")):
        print("SKIP: pvpython or xvfb-run missing")
        return SKIP
    tmp = tempfile.mkdtemp(prefix="sparkdem_render_")
    failures = []
    try:
        out = os.path.join(tmp, "out")
        subprocess.run([a.sparkdem, "run", os.path.join(REPO, "tests/scenario/data/joule_press_small.json"), "-o", out,
                        "--quiet", "--threads", "1"], check=True)
        view = os.path.join(tmp, "view.json")
        with open(view, "w") as f:
            json.dump({"particles": {"color_by": "electric_potential"},
                       "lines": {"set": "electrical", "color_by": "current"}, "size": [400, 300]}, f)
        png = os.path.join(tmp, "picture.png")
        rc = subprocess.call([sys.executable, os.path.join(REPO, "tools/render.py"), os.path.join(out, "results.xdmf"),
                              "-o", png, "--view", view])
        if rc != 0 or not os.path.isfile(png) or os.path.getsize(png) == 0:
            failures.append("render.py exited %d, picture %s" % (rc, "written" if os.path.isfile(png) else "missing"))
        else:
            w, h, drawn = map(int, subprocess.run(["pvpython", "-c", COUNT, png], capture_output=True, text=True,
                                                  check=True).stdout.split()[-3:])
            print("picture %dx%d, %d pixels not background" % (w, h, drawn))
            if (w, h) != (400, 300):
                failures.append("picture %dx%d, asked for 400x300" % (w, h))
            if drawn < 0.01 * w * h:
                failures.append("%d pixels differ from the background (< 1 %% of the picture)" % drawn)
        with open(view, "w") as f:
            json.dump({"particles": {"color_by": "electric_potential"}, "lens": 1, "size": [0, 1]}, f)
        bad = subprocess.run([sys.executable, os.path.join(REPO, "tools/render.py"), os.path.join(out, "results.xdmf"),
                              "-o", png + "2", "--view", view], capture_output=True, text=True)
        if bad.returncode != 2 or "/lens" not in bad.stderr or "/size" not in bad.stderr:
            failures.append("a bad view gave exit %d and %r" % (bad.returncode, bad.stderr))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for f in failures:
        print("FAIL: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
