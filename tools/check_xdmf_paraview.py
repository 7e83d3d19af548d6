#!/usr/bin/env python3
"""Opens a run's results.xdmf in ParaView (pvpython, XDMFReader) and checks every time step.

    python3 tools/check_xdmf_paraview.py --sparkdem BIN --scene SCENE.json [--workdir DIR]
        runs `BIN run SCENE.json -o WORKDIR/out --quiet --report-only --threads 1` (WORKDIR: a
        temporary directory, removed afterwards, unless given) and checks its results.xdmf;
    python3 tools/check_xdmf_paraview.py --xdmf OUTDIR/results.xdmf
        checks the results.xdmf of an existing run.

Checks (io/hdf5/results_writer.hpp; docs/running.md, "Outputs"):
  - ParaView's time steps are the times of the XDMF grids, one per grid (one per frame file, every
    file in OUTDIR/frames referenced by exactly one grid; a sweep's sweep_<stage>/results.xdmf:
    every referenced item frame exists);
  - at every time step the reader gives one unstructured grid (not a multiblock: two grids within
    2.2e-16 s of each other become an empty one) with as many points as the frame file's
    /particles/position has rows (read with h5ls; without it, the count the XDMF declares);
  - every particle field the grid declares, at least velocity, omega, force, radius, id and
    material, is a point array with its number of components;
  - a run that draws line sets (output.network: contacts, bonds, a module's network) gives a
    multiblock whose block "particles" is the particle grid above and whose other blocks are the
    line sets, each with the cells its frame's <group>/nodes holds, every cell a line between the
    two points of its row (the ids at its points are the row's /pairs; a wall end is the other
    end's point), and every declared field a cell array with its components.
Prints one line per time step. Exit codes: 0 every check passed, 1 a check failed (or the run
did), 77 pvpython is not on PATH (ctest SKIP_RETURN_CODE: install python3-paraview to run it).
Run it with plain python3: the ParaView part re-runs this script under pvpython.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

SKIP = 77
ALWAYS = ["velocity", "omega", "force", "radius", "id", "material"]  # every frame has them


def line_sets_of(xdmf):
    """{set name: [per frame: (cells, nodes dataset or None, {field: components})]} of the line
    collections (every temporal collection but "particles")."""
    root = ET.parse(xdmf).getroot()
    out = {}
    for c in root.iter("Grid"):
        if c.get("CollectionType") != "Temporal" or c.get("Name") == "particles":
            continue
        entries = []
        for g in c.findall("Grid"):
            topo = g.find("Topology")
            item = topo.find("DataItem")
            fields = {a.get("Name"): int(a.find("DataItem").get("Dimensions").split()[1]) for a in g.findall("Attribute")}
            entries.append((int(topo.get("NumberOfElements")), item.text.strip() if item is not None else None, fields))
        out[c.get("Name")] = entries
    return out


def grids_of(xdmf):
    """The grids of the particle collection: listed time, Information, file, declared fields."""
    root = ET.parse(xdmf).getroot()
    collections = [g for g in root.iter("Grid") if g.get("CollectionType") == "Temporal" and g.get("Name") == "particles"]
    if len(collections) != 1:
        raise SystemExit("FAIL: %s has %d temporal collections named particles, expected 1" % (xdmf, len(collections)))
    out = []
    for g in collections[0].findall("Grid"):
        info = {i.get("Name"): i.get("Value") for i in g.findall("Information")}
        items = [d.text.strip() for d in g.iter("DataItem")]
        files = sorted({i.split(":", 1)[0] for i in items})
        fields = {}
        for a in g.findall("Attribute"):
            dims = a.find("DataItem").get("Dimensions").split()
            fields[a.get("Name")] = int(dims[1])
        out.append({"name": g.get("Name"), "time": float(g.find("Time").get("Value")), "info": info, "files": files,
                    "declared": int(g.find("Topology").get("NumberOfElements")), "fields": fields})
    return out


def position_rows(frame):
    """Rows of /particles/position of a frame file (h5ls), or None without h5ls."""
    if not shutil.which("h5ls"):
        return None
    text = subprocess.run(["h5ls", frame + "/particles/position"], check=True, capture_output=True, text=True).stdout
    m = re.search(r"Dataset \{(\d+), 3", text)
    if not m:
        raise SystemExit("FAIL: h5ls %s/particles/position: %r" % (frame, text))
    return int(m.group(1))


def named_blocks(data):
    """{name: dataset} of a multiblock's direct blocks."""
    if data.GetClassName() != "vtkMultiBlockDataSet":
        return {}
    return {data.GetMetaData(b).Get(data.NAME()): data.GetBlock(b) for b in range(data.GetNumberOfBlocks())}


def check_line_block(block, particles, entry, outdir):
    """Problems of one line block against its XDMF entry and its frame file's datasets."""
    import h5py
    import numpy as np
    from vtk.util.numpy_support import vtk_to_numpy

    cells, nodes_item, fields = entry
    problems = []
    if block.GetNumberOfCells() != cells:
        return ["%d cells, the XDMF declares %d" % (block.GetNumberOfCells(), cells)]
    if cells == 0:
        return problems
    file, group = nodes_item.split(":", 1)
    group = group.rsplit("/", 1)[0]
    with h5py.File(os.path.join(outdir, file), "r") as h5:
        pairs, nodes = h5[group + "/pairs"][...], h5[group + "/nodes"][...]
    if len(nodes) != cells:
        problems.append("%d cells, %s/nodes holds %d rows" % (cells, group, len(nodes)))
    ids = vtk_to_numpy(particles.GetPointData().GetArray("id"))
    conn = np.array([[block.GetCell(c).GetPointId(0), block.GetCell(c).GetPointId(1)] for c in range(cells)])
    if any(block.GetCellType(c) not in (3, 4) or block.GetCell(c).GetNumberOfPoints() != 2 for c in range(cells)):
        problems.append("a cell is not a line of 2 points")  # VTK_LINE or VTK_POLY_LINE (XDMF's Polyline)
    want = np.where(pairs >= 0, pairs, pairs[:, ::-1])  # a wall end: the other end's particle
    if not np.array_equal(ids[conn].astype(np.int64), want):
        problems.append("cells whose points' ids are not their rows' pairs: %d" % int(np.sum(np.any(ids[conn] != want, axis=1))))
    arrays = {block.GetCellData().GetArrayName(i): block.GetCellData().GetArray(i).GetNumberOfComponents()
              for i in range(block.GetCellData().GetNumberOfArrays())}
    for name, components in fields.items():
        if arrays.get(name) != components:
            problems.append("cell array %s: %s components, expected %d" % (name, arrays.get(name), components))
    return problems


def check_in_paraview(xdmf):
    """The ParaView part (runs under pvpython); returns the number of failures."""
    from paraview import servermanager
    from paraview.simple import XDMFReader

    outdir = os.path.dirname(os.path.abspath(xdmf))
    grids = grids_of(xdmf)
    failures = []
    fail = failures.append
    lines = line_sets_of(xdmf)
    referenced = [f for g in grids for f in g["files"]]
    if os.path.isdir(os.path.join(outdir, "frames")):
        on_disk = sorted("frames/" + f for f in os.listdir(os.path.join(outdir, "frames")) if f.endswith(".h5"))
    else:  # a sweep's results.xdmf: the items' last frames (<item>/frames/...)
        on_disk = sorted(f for f in referenced if os.path.isfile(os.path.join(outdir, f)))
    if sorted(referenced) != on_disk or any(len(g["files"]) != 1 for g in grids):
        fail("frame files referenced %s, on disk %s" % (referenced, on_disk))
    reader = XDMFReader(FileNames=[xdmf])
    steps = list(reader.TimestepValues)
    print("%s: %d grids, ParaView time steps %s" % (xdmf, len(grids), steps))
    if len(steps) != len(grids) or any(abs(s - g["time"]) > 1e-300 for s, g in zip(steps, grids)):
        fail("time steps %s, expected the grid times %s" % (steps, [g["time"] for g in grids]))
    for k, t in enumerate(steps):
        reader.UpdatePipeline(t)
        data = servermanager.Fetch(reader)
        if lines:
            blocks = named_blocks(data)
            if sorted(blocks) != sorted(["particles"] + list(lines)):
                fail("t = %.17g s: blocks %s, expected particles and %s" % (t, sorted(blocks), sorted(lines)))
                continue
            for name, entries in lines.items():
                if len(entries) != len(grids):
                    fail("line set %s: %d grids for %d frames" % (name, len(entries), len(grids)))
                    continue
                problems = check_line_block(blocks[name], blocks["particles"], entries[k], outdir)
                print("t = %.17g s: %s: %d cells%s" % (t, name, blocks[name].GetNumberOfCells(), "; " + "; ".join(problems) if problems else " ok"))
                for p in problems:
                    fail("t = %.17g s: %s: %s" % (t, name, p))
            data = blocks["particles"]
        points = data.GetNumberOfPoints()
        arrays = {data.GetPointData().GetArrayName(k): data.GetPointData().GetArray(k).GetNumberOfComponents()
                  for k in range(data.GetPointData().GetNumberOfArrays())}
        at = [g for g in grids if abs(g["time"] - t) <= 2.3e-16]  # what the reader takes for time t
        if len(at) != 1:
            print("t = %.17g s: %d points, %d grids at this time (%s)" % (t, points, len(at), [g["name"] for g in at]))
            fail("t = %.17g s: %d grids within 2.2e-16 s (ParaView shows them as one multiblock)" % (t, len(at)))
            continue
        g = at[0]
        rows = position_rows(os.path.join(outdir, g["files"][0]))
        expected = rows if rows is not None else g["declared"]
        wanted = dict(g["fields"])
        problems = []
        if data.GetClassName() != "vtkUnstructuredGrid":
            problems.append("a %s, not one grid" % data.GetClassName())
        if points != expected or expected == 0:
            problems.append("%d points, the frame has %d particles" % (points, expected))
        for name in ALWAYS:
            if name not in wanted:
                problems.append("the XDMF grid declares no field %s" % name)
        for name, components in sorted(wanted.items()):
            if arrays.get(name) != components:
                problems.append("point array %s: %s components, expected %d" % (name, arrays.get(name), components))
        print("t = %.17g s (true %s s, step %s, stage '%s', %s): %d points of %s particles%s, point arrays %s: %s"
              % (t, g["info"].get("time"), g["info"].get("step"), g["info"].get("stage"), g["files"][0], points,
                 expected, "" if rows is not None else " (declared; no h5ls)", " ".join(sorted(arrays)),
                 "; ".join(problems) if problems else "ok"))
        for p in problems:
            fail("t = %.17g s: %s" % (t, p))
    for f in failures:
        print("FAIL: " + f)
    print("%d time steps checked, %d failure(s)" % (len(steps), len(failures)))
    return len(failures)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--xdmf", help="results.xdmf of an existing run")
    ap.add_argument("--sparkdem", help="sparkdem executable (with --scene)")
    ap.add_argument("--scene", help="scenario to run first (with --sparkdem)")
    ap.add_argument("--workdir", help="where the run goes (default: a temporary directory, removed)")
    ap.add_argument("--inside-pvpython", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.inside_pvpython:
        return 1 if check_in_paraview(a.xdmf) else 0
    pvpython = shutil.which("pvpython")
    if not pvpython:
        print("SKIP: pvpython is not on PATH (install python3-paraview to open results.xdmf in ParaView)")
        return SKIP
    if bool(a.xdmf) == bool(a.scene and a.sparkdem):
        ap.error("give --xdmf, or --sparkdem and --scene")
    tmp = None
    try:
        xdmf = a.xdmf
        if not xdmf:
            workdir = a.workdir or tempfile.mkdtemp(prefix="sparkdem_xdmf_paraview_")
            tmp = None if a.workdir else workdir
            out = os.path.join(workdir, "out")
            cmd = [a.sparkdem, "run", a.scene, "-o", out, "--quiet", "--report-only", "--threads", "1"]
            rc = subprocess.call(cmd)
            if rc != 0:
                print("FAIL: %s exited with %d" % (" ".join(cmd), rc))
                return 1
            xdmf = os.path.join(out, "results.xdmf")
        return subprocess.call([pvpython, os.path.abspath(__file__), "--inside-pvpython", "--xdmf", os.path.abspath(xdmf)])
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
