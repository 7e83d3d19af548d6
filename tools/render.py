#!/usr/bin/env python3
"""Renders a frame of a run to PNG with ParaView (pvpython, off-screen).

    python3 -m tools.render OUTDIR/results.xdmf -o picture.png [--view VIEW.json] [--frame K]

OUTDIR/results.xdmf is read with ParaView's XDMF reader (the file a user opens); the particles
are drawn as spheres of their radius coloured by a particle field, optionally with a line set of
the frame (contacts, bonds, a module's network such as "electrical") as tubes coloured by one of
its cell fields, and optionally cut by a clip plane. The view file is a small JSON object, every
key optional:

    {
      "frame": -1,                        # frame index (ParaView time step), negative from the end
      "particles": {"color_by": "electric_potential",   # particle field; a vector: its magnitude
                    "component": -1,                     # a vector's component (0, 1, 2; -1 magnitude)
                    "range": null,                       # [min, max] of the colour map (default: the data's)
                    "opacity": 1.0, "show": true},
      "lines": {"set": "electrical", "color_by": "current", "component": -1, "range": null,
                "absolute": true,                        # colour by |value| (currents change sign)
                "where": {"field": "broken", "equals": 1},   # draw only these cells (optional)
                "radius_fraction": 0.2},                 # tube radius / mean particle radius
      "clip": {"origin": [x, y, z], "normal": [0, 1, 0]},   # keeps the side the normal points away from
      "camera": {"direction": [1, -1, 0.6], "up": [0, 0, 1], "zoom": 1.0},
      "size": [1200, 900],
      "title": "text drawn at the top (default: stage, step and time of the frame)"
    }

"--frame" overrides the view's frame. Without a DISPLAY the ParaView part runs under `xvfb-run`
(Debian: xvfb, xauth). Exit codes: 0 written, 1 failed, 2 bad view or arguments, 77 pvpython (or,
without a display, xvfb-run) is missing (ctest's SKIP_RETURN_CODE: install python3-paraview).
Run it with plain python3: the ParaView part re-runs this script under pvpython.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

SKIP = 77
DEFAULT_VIEW = {
    "frame": -1,
    "particles": {"color_by": "radius", "component": -1, "range": None, "opacity": 1.0, "show": True},
    "lines": None,
    "clip": None,
    "camera": {"direction": [1.0, -1.0, 0.6], "up": [0.0, 0.0, 1.0], "zoom": 1.0},
    "size": [1200, 900],
    "title": None,
}
LINE_DEFAULTS = {"set": "contacts", "color_by": None, "component": -1, "range": None, "absolute": True, "where": None,
                 "radius_fraction": 0.2}


def load_view(path):
    """The view (DEFAULT_VIEW with the file's keys); SystemExit(2) naming every bad key."""
    view = json.loads(json.dumps(DEFAULT_VIEW))
    if not path:
        return view
    try:
        with open(path) as f:
            given = json.load(f)
    except (OSError, ValueError) as e:
        print("render: view file %s: %s" % (path, e), file=sys.stderr)
        sys.exit(2)
    errors = []
    if not isinstance(given, dict):
        errors.append("/: expected an object, found %s" % type(given).__name__)
        given = {}
    for key, value in given.items():
        if key not in DEFAULT_VIEW:
            errors.append("/%s: unknown key (expected one of %s)" % (key, ", ".join(DEFAULT_VIEW)))
        elif key in ("particles", "camera") and not isinstance(value, dict):
            errors.append("/%s: expected an object, found %r" % (key, value))
        elif key in ("particles", "camera"):
            view[key].update(value)
        elif key == "lines" and value is not None:
            if not isinstance(value, dict):
                errors.append("/lines: expected an object or null, found %r" % (value,))
            else:
                unknown = sorted(set(value) - set(LINE_DEFAULTS))
                if unknown:
                    errors.append("/lines: unknown keys %s (expected %s)" % (unknown, ", ".join(LINE_DEFAULTS)))
                view["lines"] = dict(LINE_DEFAULTS, **value)
        elif key == "clip" and value is not None and not (
                isinstance(value, dict) and len(value.get("origin", [])) == 3 and len(value.get("normal", [])) == 3):
            errors.append("/clip: expected {\"origin\": [x, y, z], \"normal\": [nx, ny, nz]}, found %r" % (value,))
        elif key == "size" and not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, int) and v > 0 for v in value)):
            errors.append("/size: expected [width, height] in pixels, found %r" % (value,))
        elif key == "frame" and not isinstance(value, int):
            errors.append("/frame: expected an integer, found %r" % (value,))
        else:
            view[key] = value
    if errors:
        for e in errors:
            print("render: view file %s: %s" % (path, e), file=sys.stderr)
        sys.exit(2)
    return view


def blocks_of(reader):
    """{name: flat block index} of the reader's multiblock output ({} for a single grid)."""
    from paraview import servermanager
    data = servermanager.Fetch(reader)
    if data.GetClassName() != "vtkMultiBlockDataSet":
        return {}
    return {data.GetMetaData(b).Get(data.NAME()): b + 1 for b in range(data.GetNumberOfBlocks())}


def extract(source, blocks, name):
    """The block `name` of a multiblock source (the source itself when it is one grid)."""
    import paraview.simple as pv
    if not blocks:
        return source
    if name not in blocks:
        raise SystemExit("render: the frame has no block %r (it has %s)" % (name, ", ".join(sorted(blocks))))
    out = pv.ExtractBlock(Input=source)
    out.Selectors = ["/Root/" + name]
    return pv.MergeBlocks(Input=out)


def color(display, view, association, field, component, value_range, title):
    """Colours `display` by a field ("POINTS" or "CELLS"); component -1: magnitude."""
    import paraview.simple as pv
    pv.ColorBy(display, (association, field, "Magnitude" if component < 0 else str(component)))
    lut = pv.GetColorTransferFunction(field)
    if component < 0:
        lut.VectorMode = "Magnitude"
    else:
        lut.VectorMode = "Component"
        lut.VectorComponent = component
    if value_range:
        lut.RescaleTransferFunction(float(value_range[0]), float(value_range[1]))
    else:
        display.RescaleTransferFunctionToDataRange(True, False)
    display.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(lut, view)
    bar.Title = title
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.0, 0.0, 0.0]
    bar.RangeLabelFormat = "%-#.3g"
    return lut


def render(xdmf, out, view_spec):
    """The ParaView part (runs under pvpython)."""
    import paraview.simple as pv
    from paraview import servermanager

    reader = pv.XDMFReader(FileNames=[xdmf])
    times = list(reader.TimestepValues) or [0.0]
    k = view_spec["frame"]
    if not -len(times) <= k < len(times):
        raise SystemExit("render: frame %d out of range (%d frames)" % (k, len(times)))
    t = times[k]
    reader.UpdatePipeline(t)
    blocks = blocks_of(reader)
    view = pv.CreateView("RenderView")
    view.ViewSize = list(view_spec["size"])
    view.ViewTime = t
    view.OrientationAxesVisibility = 1
    view.Background = [1.0, 1.0, 1.0]
    try:  # ParaView >= 5.10: the palette's background wins unless told otherwise
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    particles = extract(reader, blocks, "particles")
    clip = view_spec["clip"]

    def clipped(source):
        if not clip:
            return source
        c = pv.Clip(Input=source)
        c.ClipType = "Plane"
        c.ClipType.Origin = clip["origin"]
        c.ClipType.Normal = clip["normal"]
        c.Crinkleclip = 1  # whole spheres and whole lines, not cut ones
        return c

    shown = []
    p = view_spec["particles"]
    data = servermanager.Fetch(particles)
    radius = data.GetPointData().GetArray("radius")
    mean_radius = sum(radius.GetValue(i) for i in range(radius.GetNumberOfTuples())) / max(1, radius.GetNumberOfTuples())
    if p.get("show", True):
        source = clipped(particles)
        d = pv.Show(source, view)
        d.SetRepresentationType("Point Gaussian")
        d.ShaderPreset = "Sphere"
        d.ScaleByArray = 1
        d.SetScaleArray = ["POINTS", "radius"]
        d.ScaleTransferFunction.RescaleTransferFunction(0.0, 1.0)
        d.ScaleTransferFunction.Points = [0.0, 0.0, 0.5, 0.0, 1.0, 1.0, 0.5, 0.0]
        d.GaussianRadius = 1.0
        d.Opacity = float(p.get("opacity", 1.0))
        if data.GetPointData().GetArray(p["color_by"]) is None:
            raise SystemExit("render: the particles have no field %r" % p["color_by"])
        color(d, view, "POINTS", p["color_by"], int(p.get("component", -1)), p.get("range"), p["color_by"])
        shown.append(source)
    lines = view_spec["lines"]
    if lines:
        source = extract(reader, blocks, lines["set"])
        where = lines.get("where")
        if where:
            th = pv.Threshold(Input=source)
            th.Scalars = ["CELLS", where["field"]]
            th.LowerThreshold = float(where["equals"])
            th.UpperThreshold = float(where["equals"])
            source = th
        field = lines.get("color_by")
        if field and lines.get("absolute", True):
            calc = pv.Calculator(Input=source)
            calc.AttributeType = "Cell Data"
            calc.ResultArrayName = "|%s|" % field
            calc.Function = "abs(%s)" % field if int(lines.get("component", -1)) < 0 and not is_vector(source, field) else "mag(%s)" % field
            source, field = calc, "|%s|" % field
        source = clipped(source)
        tubes = pv.Tube(Input=pv.ExtractSurface(Input=source))
        tubes.Radius = float(lines.get("radius_fraction", 0.2)) * mean_radius
        tubes.NumberofSides = 12
        d = pv.Show(tubes, view)
        if field:
            color(d, view, "CELLS", field, -1 if field.startswith("|") else int(lines.get("component", -1)), lines.get("range"),
                  "%s: %s" % (lines["set"], field))
        else:
            d.AmbientColor = d.DiffuseColor = [0.2, 0.2, 0.2]
        shown.append(tubes)
    info = frame_info(xdmf, k)
    text = pv.Text(Text=view_spec["title"] or "stage %s, step %s, t = %.6g s" % (info.get("stage", ""), info.get("step", ""),
                                                                             float(info.get("time", "nan"))))
    td = pv.Show(text, view)
    td.WindowLocation = "Upper Center"
    td.FontSize = 14
    td.Color = [0.0, 0.0, 0.0]
    cam = view_spec["camera"]
    view.CameraPosition = [float(x) for x in cam.get("direction", [1, -1, 0.6])]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [float(x) for x in cam.get("up", [0, 0, 1])]
    view.ResetCamera()
    view.CameraParallelProjection = 0
    pv.GetActiveCamera().Zoom(float(cam.get("zoom", 1.0)))
    pv.SaveScreenshot(out, view, ImageResolution=list(view_spec["size"]), TransparentBackground=0)
    print("render: %s (frame %d of %d, t = %.9g s)" % (out, k % len(times), len(times), t))


def is_vector(source, field):
    """Whether the cell field `field` of `source` has more than one component."""
    from paraview import servermanager
    data = servermanager.Fetch(source)
    if data.GetClassName() == "vtkMultiBlockDataSet":
        data = data.GetBlock(0)
    array = data.GetCellData().GetArray(field) if data is not None else None
    if array is None:
        raise SystemExit("render: the line set has no cell field %r" % field)
    return array.GetNumberOfComponents() > 1


def frame_info(xdmf, k):
    """The Information (time, step, stage) of particle frame k of results.xdmf."""
    import xml.etree.ElementTree as ET
    root = ET.parse(xdmf).getroot()
    for c in root.iter("Grid"):
        if c.get("CollectionType") == "Temporal" and c.get("Name") == "particles":
            grids = c.findall("Grid")
            return {i.get("Name"): i.get("Value") for i in grids[k].findall("Information")} if grids else {}
    return {}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("xdmf", help="OUTDIR/results.xdmf of a run")
    ap.add_argument("-o", "--output", required=True, help="PNG file to write")
    ap.add_argument("--view", help="view file (JSON, see above)")
    ap.add_argument("--frame", type=int, help="frame index (overrides the view's; negative from the end)")
    ap.add_argument("--inside-pvpython", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    view = load_view(a.view)
    if a.frame is not None:
        view["frame"] = a.frame
    if not os.path.isfile(a.xdmf):
        print("render: %s: no such file" % a.xdmf, file=sys.stderr)
        return 2
    if a.inside_pvpython:
        tmp = a.output + ".tmp.png"
        render(os.path.abspath(a.xdmf), tmp, view)
        os.replace(tmp, a.output)  # never a half-written picture
        sys.stdout.flush()
        os._exit(0)  # (ParaView's teardown under Xvfb can fail with GLXBadContext after the picture is written)
    pvpython = shutil.which("pvpython")
    if not pvpython:
        print("SKIP: pvpython is not on PATH (install python3-paraview to render frames)")
        return SKIP
    cmd = [pvpython, os.path.abspath(__file__), "--inside-pvpython", os.path.abspath(a.xdmf), "-o", os.path.abspath(a.output)]
    if a.view:
        cmd += ["--view", os.path.abspath(a.view)]
    if a.frame is not None:
        cmd += ["--frame", str(a.frame)]
    if not os.environ.get("DISPLAY"):
        xvfb = shutil.which("xvfb-run")
        if not xvfb:
            print("SKIP: no DISPLAY and no xvfb-run (install xvfb and xauth to render off-screen)")
            return SKIP
        cmd = [xvfb, "-a", "-s", "-screen 0 %dx%dx24" % (max(view["size"][0], 640), max(view["size"][1], 480))] + cmd
        # Xvfb can refuse the first connection on a loaded machine ("bad X server connection",
        # seen 1 in ~6 runs beside two validation jobs): a fresh server is tried up to twice more.
        for attempt in range(3):
            run = subprocess.run(cmd, stderr=subprocess.PIPE, text=True)
            sys.stderr.write(run.stderr)
            if run.returncode == 0 or "bad X server connection" not in run.stderr:
                break
            print("render: the X server refused the connection; trying a new one", file=sys.stderr)
        return 1 if run.returncode else 0
    return 1 if subprocess.call(cmd) else 0


if __name__ == "__main__":
    sys.exit(main())
