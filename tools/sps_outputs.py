"""Readers for the outputs of an SPS pipeline run (summary.json, snapshot HDF5 files, timeseries.csv),
shared by tools/plot_sps.py and the analyzers of benchmarks/sps_*; absolute_includes for the
benchmarks' variant scenes.

Snapshots are checkpoint-format HDF5: per-contact state in state/contacts/state (one row per
contact, columns named by the space-separated string state/contacts/state_columns), the pair in
state/contacts/id_i / id_j (particle ids), particles in state/particles/id and radius.
Needs numpy and h5py (Debian python3-h5py).
"""
import numpy as np

NECK_BINS = 10


def absolute_includes(node, config_dir):
    """Make every "$include" of a scene loaded from `config_dir` absolute (in place), so that a
    variant of it can be written anywhere."""
    import os
    if isinstance(node, dict):
        if "$include" in node:
            node["$include"] = os.path.join(config_dir, node["$include"])
        for v in node.values():
            absolute_includes(v, config_dir)
    elif isinstance(node, list):
        for v in node:
            absolute_includes(v, config_dir)


def find_stage(summary, name):
    """The stage of summary.json named `name`, or None."""
    return next((s for s in summary["stages"] if s["name"] == name), None)


def neck_ratios(h5_path):
    """a / r_min over the sintered necks (neck_radius > 0) of one snapshot file; r_min is the smaller
    radius of the contact's two particles."""
    import h5py
    with h5py.File(h5_path, "r") as f:
        cols = f["state/contacts/state_columns"][()].decode().split()
        a = f["state/contacts/state"][:, cols.index("neck_radius")]
        rad = dict(zip(f["state/particles/id"][:].tolist(), f["state/particles/radius"][:].tolist()))
        ri = np.array([rad[i] for i in f["state/contacts/id_i"][:].tolist()])
        rj = np.array([rad[j] for j in f["state/contacts/id_j"][:].tolist()])
    neck = a > 0
    return a[neck] / np.minimum(ri, rj)[neck]


def neck_histogram(x):
    """Fractions of necks in NECK_BINS equal bins of a / r_min on [0, 1] (all zero if no neck)."""
    hist, _ = np.histogram(x, bins=NECK_BINS, range=(0.0, 1.0))
    return hist / max(1, len(x))


def snapshots(out_dir, stage):
    """The snapshots taken by `stage` (its summary.json entry), in order: each record of
    snapshots.taken (index = position in snapshots.at, target, value, step, time, file) with the
    necks of its file: necks (count), mean_a_over_rmin (nan without necks), hist (neck_histogram)."""
    import os
    res = []
    for s in stage.get("snapshots", {}).get("taken", []):
        x = neck_ratios(os.path.join(out_dir, s["file"]))
        res.append(dict(s, necks=int(x.size), mean_a_over_rmin=float(x.mean()) if x.size else float("nan"),
                        hist=neck_histogram(x).tolist()))
    return res


def timeseries(out_dir):
    """timeseries.csv of a run as {column: numpy array} (non-numeric or empty cells are nan)."""
    import csv, os
    rows = list(csv.DictReader(open(os.path.join(out_dir, "timeseries.csv"))))

    def num(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return float("nan")
    return {c: np.array([num(r.get(c)) for r in rows]) for c in (rows[0].keys() if rows else [])}


def sweep_values(summary, stage_name, column="electrical_conductivity_eff"):
    """{snapshot_index: value of `column`} over the sweep rows of stage `stage_name` ({} if absent).
    For a calibrating sweep only its validation rows (every snapshot at the calibrated value) count;
    the scan and search rows are the calibration map (calibration_map)."""
    st = find_stage(summary, stage_name)
    if not st or "sweep" not in st:
        return {}
    return {row["snapshot_index"]: row["values"][column] for row in st["sweep"]["rows"]
            if column in row.get("values", {}) and row.get("phase", "validate") == "validate"}


def calibration(summary, stage_name):
    """The calibration record of a calibrating sweep stage (value, achieved, map of [value, column]
    pairs, parameter, target), or None."""
    st = find_stage(summary, stage_name)
    if not st or "sweep" not in st:
        return None
    return st["sweep"].get("calibration")


# Issue 36's quasi-static gates of a hot press, fixed before kappa is compared (the explicit path):
# kinetic energy below 1e-4 of the punch work; core and compact mass porosity within 0.02; the
# compact's envelope within 1 % of the die radius while pressed; no neck-histogram bin above 25 %
# (seed 000 Fig. 6's axis). The median a / r_min rising with density is checked across snapshots.
GATES = {"ke_over_punch_work": lambda v: v <= 1e-4, "core_minus_compact_porosity": lambda v: abs(v) < 0.02,
         "envelope_over_die_radius": lambda v: v >= 0.99, "neck_max_bin_percent": lambda v: v <= 25.0}
# The quantities reported per snapshot: the gated ones and the neck statistics beside them.
QUANTITIES = ("ke_over_punch_work", "core_minus_compact_porosity", "envelope_over_die_radius", "neck_max_bin_percent",
              "neck_median_a_over_rmin", "neck_last_bin_percent")


def quasi_static_gates(columns, punch="top"):
    """The gate quantities of one snapshot from its time-series columns (summary.json
    snapshots.taken[k].columns; the stage needs the keys "compact" and "necks"), each with its
    verdict: {name: value, name + "_pass": bool}; a quantity the stage did not monitor is None."""
    def col(name):
        v = columns.get(name)
        return float(v) if v is not None else None

    ke, work = col("kinetic_energy"), col(f"wall_{punch}_work")
    core, compact = col("porosity_mass_interior"), col("porosity_mass")
    env, die = col("envelope_radius"), col("die_radius")
    vals = {"ke_over_punch_work": ke / work if ke is not None and work else None,
            "core_minus_compact_porosity": core - compact if core is not None and compact is not None else None,
            "envelope_over_die_radius": env / die if env is not None and die else None,
            "neck_max_bin_percent": col("neck_max_bin_percent"),
            "neck_median_a_over_rmin": col("neck_median_a_over_rmin"),
            "neck_last_bin_percent": col("neck_last_bin_percent")}
    out = dict(vals)
    for name, passes in GATES.items():
        out[name + "_pass"] = None if vals[name] is None else passes(vals[name])
    return out


# Issue 59's gates of a uniform hot press, fixed before kappa is compared (they replace issue 36's
# core-minus-compact and all-bins gates, which no press of this size distribution can meet):
#   G1 uniform: the interior's relative density (by mass, one largest diameter from every wall:
#      the compact monitor's porosity_mass_interior) over the whole sample's rises by at most 2 %
#      over the same ratio in the packing before the press (a uniform compaction keeps it);
#   G2 die: the 99.5th percentile over particles of (distance from the die axis + radius) is at
#      least 0.99 of the die radius;
#   G4 necks (seed 000 Fig. 6) on the necks the network uses (after Eqs. 21-25: the sintered_neck
#      network's network_neck_* columns): the last bin (0.9-1.0) at most 25 %, and the median
#      rising strictly over the snapshots (checked across snapshots: median_rises).
# G3 (rate: kappa without the layer moves < 1 % at half the rate) needs a second run.
UNIFORM_GATES = {"g1_density_ratio_rise": lambda v: v <= 0.02, "g2_envelope_p995_over_die": lambda v: v >= 0.99,
                 "g4_network_neck_last_bin_percent": lambda v: v <= 25.0}


def density_ratio(columns):
    """Interior over whole relative density by mass from compact-monitor columns (None if absent)."""
    core, whole = columns.get("porosity_mass_interior"), columns.get("porosity_mass")
    if core is None or whole is None or not np.isfinite(float(core)) or not np.isfinite(float(whole)):
        return None
    return (1.0 - float(core)) / (1.0 - float(whole))


def envelope_p995(h5_path, die="die"):
    """The 99.5th percentile over particles of (distance from the die axis + radius) over the die
    radius, from a checkpoint-format snapshot (state/walls/<die>/geometry: point, axis, radius)."""
    import h5py
    with h5py.File(h5_path, "r") as f:
        x = f["state/particles/position"][()]
        r = f["state/particles/radius"][()]
        g = f[f"state/walls/{die}/geometry"][()][0]  # axis point (3), axis (3), radius at u = 0
        u = float(f[f"state/walls/{die}/u"][()])
    point, axis = g[0:3], g[3:6] / np.linalg.norm(g[3:6])
    d = x - point
    radial = np.linalg.norm(d - np.outer(d @ axis, axis), axis=1)
    return float(np.percentile(radial + r, 99.5) / (g[6] - u))


def uniform_press_gates(out_dir, summary, press="hot_press", packing_stage="heat", network_sweep="conductivity_no_gb"):
    """Issue 59's gate quantities per snapshot of `press`: {snapshot index: {name: value, name + "_pass":
    bool, and beside them the packing's density ratio, the fullest network-neck bin, the median and
    the share of particles Eq. 25 binds}}, plus the key "median_rises" (bool, or None) across them.
    The packing's ratio is the first time-series row of `packing_stage` (its state before the press)."""
    import os
    ts = timeseries(out_dir)
    stage_index = next((k for k, s in enumerate(summary["stages"]) if s["name"] == packing_stage), None)
    if stage_index is None or not np.any(ts["stage"] == stage_index):
        raise ValueError(f"uniform_press_gates: no time-series row of the packing stage '{packing_stage}' in {out_dir}")
    first = int(np.argmax(ts["stage"] == stage_index))
    packing = density_ratio({c: ts[c][first] for c in ("porosity_mass_interior", "porosity_mass") if c in ts})
    rows = {}
    st = find_stage(summary, network_sweep)
    for row in (st or {}).get("sweep", {}).get("rows", []):
        if row.get("phase", "validate") == "validate" and "values" in row:
            rows[row["snapshot_index"]] = row["values"]
    out = {}
    for taken in find_stage(summary, press).get("snapshots", {}).get("taken", []):
        k, cols = taken["index"], taken.get("columns", {})
        env = (cols["envelope_p995_radius"] / cols["die_radius"] if "envelope_p995_radius" in cols  # the compact monitor's
               else envelope_p995(os.path.join(out_dir, taken["file"])))  # runs from before the column
        out[k] = uniform_gate_values(cols, rows.get(k, {}), packing, env)
    out["median_rises"] = median_rises([out[k]["network_neck_median_a_over_rmin"] for k in sorted(out)])
    return out


def uniform_gate_values(columns, network, packing_ratio, envelope_over_die):
    """One state's UNIFORM_GATES quantities, each with its verdict (name + "_pass"), and beside them
    its density ratio, the packing's, and the network's neck statistics: `columns` the compact
    monitor's, `network` the sintered_neck network's (network_neck_*), `packing_ratio` the packing's
    density_ratio, `envelope_over_die` G2's quantity."""
    ratio = density_ratio(columns)
    vals = {"g1_density_ratio_rise": ratio / packing_ratio - 1.0 if ratio is not None and packing_ratio else None,
            "g2_envelope_p995_over_die": envelope_over_die,
            "g4_network_neck_last_bin_percent": network.get("network_neck_last_bin_percent")}
    out = dict(vals, g1_density_ratio=ratio, g1_density_ratio_packing=packing_ratio,
               network_neck_max_bin_percent=network.get("network_neck_max_bin_percent"),
               network_neck_median_a_over_rmin=network.get("network_neck_median_a_over_rmin"),
               network_neck_gbf_bound_share=network.get("network_neck_gbf_bound_share"))
    for name, passes in UNIFORM_GATES.items():
        out[name + "_pass"] = None if vals[name] is None else passes(vals[name])
    return out


def median_rises(medians):
    """G4's second half: the medians rise strictly over the snapshots (None when one is missing)."""
    return all(b > a for a, b in zip(medians, medians[1:])) if medians and all(m is not None for m in medians) else None
