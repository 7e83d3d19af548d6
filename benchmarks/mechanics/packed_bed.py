"""Packed beds for the speed comparison with LAMMPS (issue 40 items 1-2).

A packed-bed scene (benchmarks/mechanics/poly_*_bed.json) has a generator stage `pack` and a
dynamics stage `bed`. The perf harness runs `pack` once, then times `bed` started from its final
state in both codes: sparkdem reads the checkpoint (`from_snapshot`), LAMMPS reads the same
particles from a data file written here (`read_data bed.data`) and the walls' positions from
`bed_walls.in` (`include`). Only the positions, velocities, spins, radii and masses carry over;
the contact history starts fresh in both codes (the bed stage has its own contact law).
"""
import math
import os


def split_stages(config):
    """(pack scene, bed stage): the config's generator stages alone, and its last dynamics stage."""
    gen = [s for s in config["stages"] if s.get("type", "dynamics") != "dynamics"]
    dyn = [s for s in config["stages"] if s.get("type", "dynamics") == "dynamics"]
    if not gen or not dyn:
        raise RuntimeError(f"{config.get('name')}: a packed bed needs a generator stage and a dynamics stage")
    return dict(config, stages=gen), dyn[-1]


def bed_scene(config, final_state):
    """The config with only its bed stage, started from the pack's final state."""
    _, bed = split_stages(config)
    bed = dict(bed, from_snapshot=os.path.abspath(final_state))
    return dict(config, stages=[bed])


def wall_variables(walls):
    """LAMMPS variables of the axis-aligned planes (xlo ... zhi) and a z-axis cylinder (die_radius)."""
    names = {(0, 1): "xlo", (0, -1): "xhi", (1, 1): "ylo", (1, -1): "yhi", (2, 1): "zlo", (2, -1): "zhi"}
    out = {}
    for name, g in walls.items():
        kind, geo, u = g["kind"], g["geometry"], g["u"]
        if kind == "plane":
            axis = max(range(3), key=lambda k: abs(geo[3 + k]))
            sign = 1 if geo[3 + axis] > 0 else -1
            if abs(abs(geo[3 + axis]) - 1.0) > 1e-12:
                raise RuntimeError(f"wall {name}: not axis-aligned ({geo[3:6]})")
            out[names[(axis, sign)]] = geo[axis] + sign * u
        elif kind == "cylinder":
            if abs(geo[0]) > 0 or abs(geo[1]) > 0 or abs(abs(geo[5]) - 1.0) > 1e-12:
                raise RuntimeError(f"wall {name}: LAMMPS's zcylinder is the z axis, got base {geo[0:3]} axis {geo[3:6]}")
            out["die_radius"] = geo[6] - u
        else:
            raise RuntimeError(f"wall {name}: unknown kind {kind}")
    return out


def write_lammps_bed(final_state, rundir):
    """bed.data (atom_style sphere: id type diameter density x y z; Velocities: v and spin) and
    bed_walls.in (`variable NAME equal VALUE` per wall) from a sparkdem checkpoint."""
    import h5py
    import numpy as np
    with h5py.File(final_state, "r") as f:
        p = f["state/particles"]
        pos, vel, omega = p["position"][()], p["velocity"][()], p["omega"][()]
        rad, mass, ident = p["radius"][()], p["mass"][()], p["id"][()]
        walls = {}
        for name in f["state/walls"]:
            g = f["state/walls/" + name]
            kind = g["kind"][()]
            walls[name] = {"kind": kind.decode() if isinstance(kind, bytes) else str(kind),
                           "geometry": [float(x) for x in np.ravel(g["geometry"][()])], "u": float(g["u"][()])}
    density = mass / (4.0 / 3.0 * math.pi * rad ** 3)
    lo = (pos - rad[:, None]).min(axis=0) - 2 * rad.max()
    hi = (pos + rad[:, None]).max(axis=0) + 2 * rad.max()
    variables = wall_variables(walls)
    for k, (a, b) in enumerate((("xlo", "xhi"), ("ylo", "yhi"), ("zlo", "zhi"))):
        if a in variables:
            lo[k] = min(lo[k], variables[a])
        if b in variables:
            hi[k] = max(hi[k], variables[b])
    os.makedirs(rundir, exist_ok=True)
    lines = ["LAMMPS data file: a sparkdem packed bed (benchmarks/mechanics/packed_bed.py)", "",
             f"{len(rad)} atoms", "1 atom types", ""]
    lines += [f"{lo[k]:.17g} {hi[k]:.17g} {a}lo {a}hi" for k, a in enumerate("xyz")]
    lines += ["", "Atoms # sphere", ""]
    lines += [f"{int(i) + 1} 1 {2 * r:.17g} {d:.17g} {x[0]:.17g} {x[1]:.17g} {x[2]:.17g}"
              for i, r, d, x in zip(ident, rad, density, pos)]
    lines += ["", "Velocities", ""]
    lines += [f"{int(i) + 1} {v[0]:.17g} {v[1]:.17g} {v[2]:.17g} {w[0]:.17g} {w[1]:.17g} {w[2]:.17g}"
              for i, v, w in zip(ident, vel, omega)]
    with open(os.path.join(rundir, "bed.data.tmp"), "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(os.path.join(rundir, "bed.data.tmp"), os.path.join(rundir, "bed.data"))
    with open(os.path.join(rundir, "bed_walls.in"), "w") as f:
        f.write("".join(f"variable        {k} equal {v:.17g}\n" for k, v in sorted(variables.items())))
    return variables
