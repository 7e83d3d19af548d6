"""Error against run time, one small panel per case, for the validation ledger (issue 34 item 4).

write_error_vs_time(records, path, verdict) draws the full-tier records of the ledger:

  * one panel per case, titled with the case name; panels are grouped by source (seed000, seed001,
    seed002, closed, then any other source), each source a block with its own heading and tint;
  * x: the record's run time, wall seconds over all its runs (log scale);
  * y: the signed error of the ensemble mean in % (linear, with a dashed zero line), or, for a
    figure whose error is an absolute difference (error_kind "absolute"), that difference x 100
    (the panel's y label says which);
  * the records of one case joined in order of N, each point labelled with its N (no label when
    N = 0), error bars +-1 seed-to-seed std where the record has one, the band as a shaded strip
    [-band, +band] where the band is a number;
  * marker by verdict(rec): filled = pass, open = miss, red x = tuned, red triangle at the panel's
    top = failed (no error value); any other verdict string gets its own marker and legend
    entry. Records of kind "calibration", "construction" or "study" are drawn grey, not judged. Records of
    kind "regression" and fast-tier records are left out. A record flagged "provisional" has
    "prov." after its N.

Everything drawn is read from the records; nothing is typed in by hand.
"""
import math
import os

SOURCE_ORDER = ["seed000", "seed001", "seed002", "closed"]
TINTS = ["#eef3fa", "#faf1e8", "#edf7ee", "#f6eef8"]
NOT_JUDGED = ("calibration", "construction", "study")
LEFT_OUT = ("regression",)
COLUMNS = 6
DPI = 120
STYLE = {  # role -> (legend label, marker, colour, filled)
    "pass": ("pass (filled)", "o", "tab:blue", True),
    "miss": ("miss (open)", "o", "tab:blue", False),
    "tuned": ("tuned after seeing (never a pass)", "x", "tab:red", True),
    "failed": ("failed: no error value (at the top)", "^", "darkred", False),
    "not judged": ("calibration/construction/study (not judged)", "D", "0.55", True),
}
SPARE_MARKERS = ["s", "P", "*", "h", "v", "<", ">"]


def _num(value):
    """value as a float when it is a finite number (not a bool, dict, None or NaN), else None."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return float(value) if ok else None


def _cases_by_source(records):
    """{source: [(case name without source, [records sorted by N])]} for the drawn records."""
    cases = {}
    for r in records:
        if r.get("tier") == "full" and r.get("kind") not in LEFT_OUT:
            cases.setdefault(r["case"], []).append(r)
    out = {}
    for case in sorted(cases):
        source, _, name = case.rpartition("/")
        out.setdefault(source or "other", []).append((name, sorted(cases[case], key=lambda r: r.get("N") or 0)))
    known = [s for s in SOURCE_ORDER if s in out]
    return {s: out[s] for s in known + sorted(set(out) - set(known))}


def _style(rec, verdict, used):
    """The role of a record (its verdict, or "not judged") and its (label, marker, colour, filled)."""
    role = "not judged" if rec.get("kind") in NOT_JUDGED else str(verdict(rec))
    if role not in used:
        spare = SPARE_MARKERS[sum(1 for k in used if k not in STYLE) % len(SPARE_MARKERS)]
        used[role] = STYLE.get(role, (f"verdict '{role}'", spare, "tab:orange", False))
    return role, used[role]


def _log_ticks(ax, lo, hi):
    """x limits spanning at least a decade around [lo, hi]; ticks at 1, 2, 5 x 10^k, plain labels."""
    from matplotlib import ticker
    lo, hi = lo / 1.5, hi * 1.5
    if hi / lo < 10:
        widen = (10 / (hi / lo)) ** 0.5
        lo, hi = lo / widen, hi * widen
    ax.set_xscale("log")
    ax.set_xlim(lo, hi)
    ax.xaxis.set_major_locator(ticker.LogLocator(base=10, subs=(1, 2, 5)))
    ax.xaxis.set_minor_formatter(ticker.NullFormatter())
    ax.xaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}" if v < 1e4 else f"{v / 1e3:g}k"))


def _point_label(rec):
    text = f"N={rec['N']}" if rec.get("N") else ""
    if rec.get("legacy"):
        text += "*"
    return (text + " prov.").strip() if rec.get("provisional") else text.strip()


def _draw_points(ax, recs, verdict, used):
    """Line, error bars and markers of one case; returns the drawn points [(x, y, dy, label)] and notes."""
    placed = [r for r in recs if (_num(r.get("wall_s")) or 0) > 0 and _num(r.get("error")) is not None]
    if len(placed) > 1:
        ax.plot([r["wall_s"] for r in placed], [100 * r["error"] for r in placed], "-", color="0.6", lw=0.9, zorder=2)
    points, notes = [], []
    for r in recs:
        role, (_, marker, colour, filled) = _style(r, verdict, used)
        x, err, std = _num(r.get("wall_s")) or 0, _num(r.get("error")), _num(r.get("std"))
        if x <= 0:
            notes.append(f"{_point_label(r) or 'the record'}: no run time, not drawn")
            continue
        if err is None:  # no value to place: a triangle near the top edge at its run time
            if role != "not judged":
                role, (_, _, colour, _) = "failed", used.setdefault("failed", STYLE["failed"])
            ax.plot([x], [0.93], marker="^", ms=7, mfc="none", mec=colour, mew=1.4, ls="none",
                    transform=ax.get_xaxis_transform(), zorder=4)
            continue
        y, dy = 100 * err, 100 * std if std is not None else 0.0
        points.append((x, y, dy, _point_label(r)))
        if dy:  # 0 or no std: no bar
            ax.errorbar([x], [y], yerr=[dy], fmt="none", ecolor=colour, elinewidth=0.9, capsize=2, zorder=3)
        ax.plot([x], [y], marker=marker, ms=6, mfc=colour if filled else "none", mec=colour, mew=1.4,
                ls="none", zorder=4)
    return points, notes


OFFSETS = [(0, 5, "center", "bottom"), (0, -6, "center", "top"), (6, 0, "left", "center"),
           (-6, 0, "right", "center"), (5, 5, "left", "bottom"), (-5, 5, "right", "bottom"),
           (5, -5, "left", "top"), (-5, -5, "right", "top")]


def _place_labels(ax, points, renderer):
    """Put each point's N label where it overlaps no marker, error bar or earlier label (after layout)."""
    from matplotlib.transforms import Bbox
    to_px = ax.transData.transform
    busy = []
    for x, y, dy, _ in points:
        px, py = to_px((x, y))
        busy.append(Bbox.from_extents(px - 5, py - 5, px + 5, py + 5))
        if dy:
            busy.append(Bbox.from_extents(px - 3, to_px((x, y - dy))[1], px + 3, to_px((x, y + dy))[1]))
    frame = ax.get_window_extent(renderer)
    for x, y, _, label in points:
        if label:
            busy.append(_best_label(ax, (x, y), label, busy, frame, renderer))


def _overlap(a, b):
    return max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0)) * max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))


def _best_label(ax, xy, label, busy, frame, renderer):
    """Annotate xy at the first offset that is inside the frame and clear of busy, else the least bad one."""
    best = None
    for dx, dy, ha, va in OFFSETS:
        t = ax.annotate(label, xy, xytext=(dx, dy), textcoords="offset points", ha=ha, va=va,
                        fontsize=6.5, color="0.2", zorder=5)
        box = t.get_window_extent(renderer)
        outside = box.width * box.height - _overlap(box, frame)
        bad = 10 * outside + sum(_overlap(box, b) for b in busy)
        if best is None or bad < best[0]:
            if best is not None:
                best[1].remove()
            best = (bad, t, box)
        else:
            t.remove()
        if bad == 0:
            break
    return best[2]


def _draw_band(ax, recs):
    """The shaded band [-band, +band]; where the band differs between N, a step strip, each band
    drawn over the run times nearest its own record's."""
    timed = sorted((r["wall_s"], 100 * r["band"]) for r in recs
                   if _num(r.get("band")) is not None and (_num(r.get("wall_s")) or 0) > 0)
    if len({b for _, b in timed}) <= 1:
        bands = [100 * r["band"] for r in recs if _num(r.get("band")) is not None]
        if bands:
            ax.axhspan(-bands[0], bands[0], color="0.85", lw=0, zorder=0)
        return
    lo, hi = ax.get_xlim()
    edges = [lo] + [(timed[i][0] * timed[i + 1][0]) ** 0.5 for i in range(len(timed) - 1)] + [hi]
    b = [band for _, band in timed] + [timed[-1][1]]
    ax.fill_between(edges, [-v for v in b], b, step="post", color="0.85", lw=0, zorder=0)


def _draw_panel(ax, name, recs, verdict, used):
    """One case: band strip, zero line, the points, limits and labels; returns its points to label."""
    bands = [100 * r["band"] for r in recs if _num(r.get("band")) is not None]
    walls = [r["wall_s"] for r in recs if (_num(r.get("wall_s")) or 0) > 0]
    points, notes = _draw_points(ax, recs, verdict, used)
    b = max(map(abs, bands)) if bands else 0.0
    ax.axhline(0, color="0.3", lw=0.7, ls="--", zorder=1)
    lo = min([-b] + [y - dy for _, y, dy, _ in points])
    hi = max([b] + [y + dy for _, y, dy, _ in points])
    pad = 0.22 * (hi - lo) or 1.0
    ax.set_ylim(lo - pad, hi + pad)
    if walls:
        _log_ticks(ax, min(walls), max(walls))
    else:
        ax.set_xscale("log")
    _draw_band(ax, recs)
    absolute = any(r.get("error_kind") == "absolute" for r in recs)
    ax.set_ylabel("absolute error x 100" if absolute else "error [%]", fontsize=7.5, labelpad=1)
    ax.set_title(name, fontsize=min(8.5, 280 / max(len(name), 1)), pad=3)  # long names: smaller, not clipped
    ax.tick_params(labelsize=7, pad=1.5)
    ax.yaxis.get_offset_text().set_fontsize(6.5)
    ax.grid(True, which="major", alpha=0.25, lw=0.5)
    if notes:
        ax.text(0.02, 0.03, "\n".join(notes), transform=ax.transAxes, fontsize=6, color="darkred", va="bottom")
    return points


def _legend_handles(used):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    shown = {k: v for k, v in STYLE.items() if k != "failed" or k in used}
    shown.update(used)
    handles = []
    for label, marker, colour, filled in shown.values():
        handles.append(Line2D([], [], marker=marker, ls="none", ms=7, mew=1.4, mec=colour,
                              mfc=colour if filled else "none", label=label))
    handles.append(Patch(color="0.85", label="band: [-band, +band]"))
    handles.append(Line2D([], [], color="0.3", lw=0.9, marker="|", ms=8, label="+-1 seed-to-seed std"))
    handles.append(Line2D([], [], color="0.6", lw=0.9, label="one case, joined in order of N"))
    return handles


NOTE = ("Full-tier records only: fast-tier records (kind regression) are left out. x: wall seconds over all runs "
        "of the record (log). y: signed error of the ensemble mean in % of the reference; figures with an absolute "
        "error (e.g. porosity): that difference x 100, as the panel's axis says. Labels: N (none when the case has "
        "no N; 'prov.': provisional; '*': legacy, no run file, cannot be recomputed, never counted). "
        "Where the band differs between N, its strip steps between their run times. "
        "Calibration/construction/study records are drawn grey and not judged.")


def write_error_vs_time(records, path, verdict):
    """Draw the per-case error-against-run-time figure of the full-tier records to path (PNG, atomic)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    groups = _cases_by_source(records)
    rows = [max(1, -(-len(cases) // COLUMNS)) for cases in groups.values()]
    heights = [1.3] + [2.3 * n + 0.45 for n in rows]  # inches: the legend head, then one block per source
    fig = plt.figure(figsize=(2.75 * COLUMNS, sum(heights)), dpi=DPI, layout="constrained")
    parts = fig.subfigures(len(heights), 1, height_ratios=heights, squeeze=False).ravel()
    used, to_label = {}, []
    for k, ((source, cases), n) in enumerate(zip(groups.items(), rows)):
        sub = parts[k + 1]
        sub.set_facecolor(TINTS[k % len(TINTS)])
        sub.suptitle(f"source {source}: {len(cases)} case{'s' * (len(cases) != 1)}", fontsize=10,
                     fontweight="bold", x=0.01, ha="left")
        axes = sub.subplots(n, COLUMNS, squeeze=False).ravel()
        for ax, (name, recs) in zip(axes, cases):
            to_label.append((ax, _draw_panel(ax, name, recs, verdict, used)))
        for ax in axes[len(cases):]:
            ax.set_visible(False)
    head = parts[0]
    head.suptitle("sparkdem validation ledger: error against run time, one panel per case", fontsize=12)
    head.legend(handles=_legend_handles(used), loc="center", ncol=4, fontsize=8, frameon=False)
    head.text(0.5, 0.02, NOTE, ha="center", va="bottom", fontsize=7, wrap=True)
    fig.canvas.draw()  # lays the panels out, so labels can be placed in their final pixels
    for ax, points in to_label:
        _place_labels(ax, points, fig.canvas.get_renderer())
    tmp = f"{path}.tmp.png"
    fig.savefig(tmp, dpi=DPI)
    plt.close(fig)
    os.replace(tmp, path)
