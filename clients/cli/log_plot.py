# The plots of `coopdyn log` (embedded in the coopdyn binary; also runs on its own):
#   python3 log_plot.py [--progress] OUTDIR STEPS.csv [STATS.csv]
# STEPS.csv is a per-step CSV (docs/conventions.md): a `coopdyn sim --out` file or the output_t
# channel of `coopdyn log`; STATS.csv the loop_stats_t channel of a log ('' or absent: none).
# Writes OUTDIR/wrenches.png (the torques and inputs, then one panel per wrench component with its
# unit and, where the CSV carries the wrench's sigma (NAME.sigma_mx, ...), a +-sigma band around it,
# then the pseudo-joint stresses), OUTDIR/reactions.png (the joint reactions) and
# OUTDIR/timing.png, all on the same time axis t (s).
#
# What is drawn, not the data, is thinned: a curve of more samples than twice its panel's width in
# pixels is drawn as the lowest and highest value of each pixel column (the same envelope; lines()
# says what it draws). A row whose status is `error` (no state, a stale state, a failed evaluation:
# its numbers are zeros, not values) is a gap in every curve and band. --progress reports each stage
# on stderr. Exits 3 when matplotlib cannot be imported (the caller says so).
import csv
import os
import sys
import time

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError:
    sys.exit(3)

T0 = time.monotonic()
PROGRESS = False


def report(what):
    if PROGRESS:
        print(f"coopdyn log: plotting: {what}, {time.monotonic() - T0:.1f} s wall", file=sys.stderr, flush=True)


class Table:
    """A CSV's columns by name: text (t["status"]) and numbers (num(), cached; NaN in the error rows
    for every column but the time axes). Only the columns asked for are parsed."""

    KEEP = ("t", "log_time", "utime", "tick")

    def __init__(self, names, lines, quoted=False):
        self.names, self.quoted = names, quoted
        self.index = {n: i for i, n in enumerate(names)}
        self.lines = lines  # the data rows' text, whole rows only
        self.n = len(lines)
        self._text, self._num = {}, {}
        self.error = np.array([s == "error" for s in self["status"]], bool) if "status" in self else np.zeros(self.n, bool)

    def __contains__(self, name):
        return name in self.index

    def __getitem__(self, name):
        cells = self._text.get(name)
        if cells is None:
            i = self.index[name]
            rows = csv.reader(self.lines) if self.quoted else (line.split(",") for line in self.lines)
            cells = self._text[name] = [r[i] for r in rows]
        return cells

    def load(self, names):
        """Parses the numbers of these columns at once (a whole-file C parser; the slow way when a cell is not one)."""
        names = [n for n in dict.fromkeys(names) if n not in self._num]
        if not self.n:
            self._num.update((n, np.zeros(0)) for n in names)
            return
        if not names:
            return
        try:
            a = np.loadtxt(self.lines, delimiter=",", usecols=[self.index[n] for n in names], dtype=float, ndmin=2,
                           quotechar='"', comments=None)
        except ValueError:  # an empty cell or text: column by column
            a = np.column_stack([numeric(self[n]) for n in names])
        for k, n in enumerate(names):
            y = np.ascontiguousarray(a[:, k])
            if n not in self.KEEP and self.error.any():
                y[self.error] = np.nan
            self._num[n] = y

    def num(self, name):
        if name not in self._num:
            self.load([name])
        return self._num[name]


def read(path, wanted=None):
    """-> (names, units by name, wrench meta {name: (kind, frame, by)}, comment lines, Table); the
    numbers of the columns for which wanted(name) is true parsed at once"""
    comments, units, meta = [], {}, {}
    with open(path, newline="") as f:
        line = f.readline()
        while line.startswith("#"):
            comments.append(line[1:].strip())
            line = f.readline()
        names = line.rstrip("\r\n").split(",")
        text = f.read()
    quoted = '"' in text  # (a text cell with a comma): the csv module's reading
    lines = text.splitlines()
    if quoted:
        rows = [line for line, r in zip(lines, csv.reader(lines)) if len(r) == len(names)]
    else:
        rows = [line for line in lines if line.count(",") == len(names) - 1]
    for c in comments:
        if c.startswith("units: "):
            units = dict(zip(names, c[len("units: "):].split(",")))
        elif c.startswith("wrench "):
            name, rest = c[len("wrench "):].split(": ", 1)
            fields = dict(p.split(" ", 1) for p in rest.split(", "))
            meta[name] = (fields.get("kind", ""), fields.get("frame", ""), fields.get("by", ""))
    table = Table(names, rows, quoted)
    if wanted:
        table.load([n for n in names if wanted(n)])
    return names, units, meta, comments, table


def number(x):
    try:
        return float(x)
    except ValueError:  # an empty cell (no value), text
        return np.nan


def numeric(cells):
    return np.array([number(x) for x in cells])


def nonzero(y):
    """Some finite sample of y is not zero."""
    return bool(np.any(np.isfinite(y) & (y != 0)))


def pixel_columns(t, finite, xlim, width):
    """The runs of samples drawn as one: the same pixel column (of `width` over xlim) and all finite
    or all not -> (first index, one past the last index) of each."""
    span = xlim[1] - xlim[0] if xlim[1] > xlim[0] else 1.0
    col = np.clip(np.floor((t - xlim[0]) / span * width), -1, width).astype(np.int64)
    cut = np.flatnonzero((col[1:] != col[:-1]) | (finite[1:] != finite[:-1])) + 1
    starts = np.concatenate(([0], cut))
    return starts, np.concatenate((cut, [len(t)]))


def lines(t, y, xlim, width):
    """What a curve of samples (t, y) draws in a panel `width` pixels wide: every sample when there
    are at most 2 per pixel column, else per column its lowest and highest value (at the column's
    first and last sample's time, in the order the curve goes); a NaN (an error row) breaks it."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if len(y) <= 2 * width:
        return t, y
    finite = np.isfinite(y)
    s, e = pixel_columns(t, finite, xlim, width)
    z = np.where(finite, y, 0.0)
    lo, hi = np.minimum.reduceat(z, s), np.maximum.reduceat(z, s)
    up = z[s] <= z[e - 1]
    first, last = np.where(up, lo, hi), np.where(up, hi, lo)
    gap = ~finite[s]
    first[gap] = last[gap] = np.nan
    tt = np.column_stack((t[s], t[e - 1])).ravel()
    return tt, np.column_stack((first, last)).ravel()


def band(t, lo, hi, xlim, width):
    """What a band lo..hi draws, thinned as lines(): per pixel column the lowest lo and highest hi."""
    t, lo, hi = (np.asarray(a, float) for a in (t, lo, hi))
    if len(t) <= 2 * width:
        return t, lo, hi
    finite = np.isfinite(lo) & np.isfinite(hi)
    s, e = pixel_columns(t, finite, xlim, width)
    a = np.minimum.reduceat(np.where(finite, lo, 0.0), s)
    b = np.maximum.reduceat(np.where(finite, hi, 0.0), s)
    a[~finite[s]] = b[~finite[s]] = np.nan
    tt = np.column_stack((t[s], t[e - 1])).ravel()
    return tt, np.repeat(a, 2), np.repeat(b, 2)


def panel_width(fig, ax):
    """The panel's width in pixels at the figure's dpi."""
    return max(1, int(ax.get_position().width * fig.get_figwidth() * fig.dpi))


def plot_curve(fig, ax, t, y, xlim, **kw):
    tt, yy = lines(t, y, xlim, panel_width(fig, ax))
    return ax.plot(tt, yy, **kw)


KIND_TEXT = {
    "end_effector": "the load's wrench on the end-effector",
    "base": "the world's wrench on the arm's base",
    "tip": "the constraint's wrench on its tip",
    "axle": "through the axle, at the wheel centre",
    "joint": "joint reaction, on the link after the joint",
}


def describe(name, kind, frame, by):
    if kind == "tip" and by == "ground":  # a rolling wheel: the ground's force at its contact
        return f"{name}: the ground on the wheel, in its contact frame {frame} (x heading, y left, z normal)"
    what = KIND_TEXT.get(kind, kind)
    return f"{name}: {what}" + (f" (by {by})" if by and kind != "joint" else "") + f", in frame {frame}"


def input_changes(cols, t):
    """[(t, input word)] where the output's input column changes (a log's outputs only)."""
    if "input" not in cols:
        return []
    out, last = [], None
    for ti, x in zip(t, cols["input"]):
        if x != last:
            out.append((ti, x))
            last = x
    return out


def error_spans(cols, t):
    """[(t0, t1)] of the runs of error rows (t1: the next row's time, or the last row's)."""
    err = cols.error
    if not err.any():
        return []
    d = np.diff(np.concatenate(([0], err.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(float(t[a]), float(t[min(b, len(t) - 1)])) for a, b in zip(starts, ends)]


ERROR_COLOR = "mistyrose"


def mark_inputs(ax, changes, t_end, label=False, errors=()):
    for i, (t0, what) in enumerate(changes):
        t1 = changes[i + 1][0] if i + 1 < len(changes) else t_end
        if what not in ("command", "state"):  # no input: shade where the daemon ran without one
            ax.axvspan(t0, t1, color="0.85", zorder=0)
        ax.axvline(t0, color="0.5", lw=0.8, ls=":")
        if label:
            ax.annotate(what.replace("_", " "), (t0, 0.97 - 0.16 * (i % 2)), xycoords=("data", "axes fraction"), xytext=(3, 0),
                        textcoords="offset points", va="top", ha="left", fontsize=8, color="0.2")
    for t0, t1 in errors:  # the error rows: a gap in the curves, shaded over the input's shading
        ax.axvspan(t0, t1, color=ERROR_COLOR, zorder=0.5, lw=0)


BAND_COLOR, BAND_ALPHA = "tab:orange", 0.3


def sigma_column(c):
    """The column of component c's standard deviation (NAME.mx -> NAME.sigma_mx)."""
    name, comp = c.rsplit(".", 1)
    return f"{name}.sigma_{comp}"


def sigma_band(fig, ax, t, y, cols, c, xlim):
    """Draws y +- sigma where the CSV carries component c's sigma (nonzero somewhere); True if drawn."""
    sc = sigma_column(c)
    if sc not in cols:
        return False
    s = cols.num(sc)
    if not np.any(s > 0):
        return False
    tt, lo, hi = band(t, y - s, y + s, xlim, panel_width(fig, ax))
    ax.fill_between(tt, lo, hi, color=BAND_COLOR, alpha=BAND_ALPHA, lw=0, zorder=1)
    return True


def wrench_figure(path, title, t, cols, units, wrenches, marks, torque_cols, stresses, xlim):
    changes, errors = marks
    comps = (("mx", "my", "mz"), ("fx", "fy", "fz"))
    rows = []  # (title, [column or None] x 3)
    for name, (kind, frame, by) in wrenches:
        for what, cs in zip(("moment", "force"), comps):
            cc = [name + "." + c for c in cs]
            if any(nonzero(cols.num(c)) for c in cc):  # all-zero rows (a wheel's moments) left out
                rows.append((describe(name, kind, frame, by) + f": {what}", cc))
    top = 1 if torque_cols else 0
    bottom = 1 if stresses else 0
    n = top + len(rows) + bottom
    if n == 0:
        return None
    report(f"drawing {path.rsplit('/', 1)[-1]} ({n} rows of panels)")
    height = 1.3 + 2.1 * n
    # fixed margins, room for the legends on the right (a tight bounding box draws the figure twice),
    # every panel's own time axis set once (shared axes propagate each limit to all the others)
    fig = plt.figure(figsize=(14.5, height), dpi=80)
    gs = fig.add_gridspec(n, 3, hspace=0.75, wspace=0.28, top=1 - 1.25 / height, bottom=0.55 / height, left=0.055,
                          right=0.86)
    axes = []
    shade = ("; red: error rows (no values)" if errors else "")

    def wide(r):
        ax = fig.add_subplot(gs[r, :])
        axes.append(ax)
        return ax

    if top:
        ax0 = wide(0)
        for c in torque_cols:
            plot_curve(fig, ax0, t, cols.num(c), xlim, lw=1.2, label=c[4:])
        ax0.set_title("applied torques tau (nonzero joints)"
                      + ("; shaded: no input, dotted: the input changes" if changes else "") + shade, fontsize=10)
        ax0.set_ylabel(units.get(torque_cols[0], ""))
        ax0.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
        mark_inputs(ax0, changes, xlim[1], label=True, errors=errors)
    for r, (rtitle, cc) in enumerate(rows):
        for k, c in enumerate(cc):
            ax = fig.add_subplot(gs[top + r, k])
            axes.append(ax)
            y = cols.num(c)
            plot_curve(fig, ax, t, y, xlim, lw=1.2)
            has_band = sigma_band(fig, ax, t, y, cols, c, xlim)
            ax.set_title(c.rsplit(".", 1)[1] + f" [{units.get(c, '')}]" + (" (band: +-sigma)" if has_band else ""),
                         fontsize=10)
            ax.ticklabel_format(axis="y", useOffset=False)
            mark_inputs(ax, changes, xlim[1], errors=errors)
            if k == 0:
                ax.text(0.0, 1.32, rtitle, transform=ax.transAxes, fontsize=10, weight="bold")
    if stresses:
        ax = wide(n - 1)
        for c in stresses:
            plot_curve(fig, ax, t, cols.num(c), xlim, lw=1.2, label=f"{c[7:]} [{units.get(c, '')}]")
        ax.set_title("pseudo-joint stresses", fontsize=10)
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
        mark_inputs(ax, changes, xlim[1], errors=errors)
    for ax in axes:
        ax.grid(True, alpha=0.4)
        ax.set_xlim(*xlim)
        ax.tick_params(labelsize=8)
    for ax in axes[-3:]:
        ax.set_xlabel("t [s]", fontsize=9)
    fig.suptitle(title, fontsize=12, y=1 - 0.15 / height)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def reactions_figure(path, title, t, cols, units, wrenches, marks, xlim):
    """The joint reactions, compact: per joint one row, its moment's three components in one panel
    and its force's in the other (a unit each), so that twelve joints draw 24 panels, not 72."""
    changes, errors = marks
    rows = []  # (title, [moment columns or None, force columns or None])
    for name, (kind, frame, by) in wrenches:
        pair = [[name + "." + c for c in cs] for cs in (("mx", "my", "mz"), ("fx", "fy", "fz"))]
        pair = [cc if any(nonzero(cols.num(c)) for c in cc) else None for cc in pair]
        if pair[0] or pair[1]:
            rows.append((describe(name, kind, frame, by), pair))
    if not rows:
        return None
    report(f"drawing {path.rsplit('/', 1)[-1]} ({len(rows)} rows of panels)")
    n = len(rows)
    height = 1.3 + 2.1 * n
    fig = plt.figure(figsize=(14.5, height), dpi=80)
    gs = fig.add_gridspec(n, 2, hspace=0.75, wspace=0.18, top=1 - 1.25 / height, bottom=0.55 / height, left=0.055,
                          right=0.9)
    axes = []
    for r, (rtitle, pair) in enumerate(rows):
        for k, cc in enumerate(pair):
            if cc is None:
                continue
            ax = fig.add_subplot(gs[r, k])
            axes.append(ax)
            for c in cc:
                plot_curve(fig, ax, t, cols.num(c), xlim, lw=1.1, label=c.rsplit(".", 1)[1])
            ax.set_title(("moment" if k == 0 else "force") + f" [{units.get(cc[0], '')}]", fontsize=10)
            ax.ticklabel_format(axis="y", useOffset=False)
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, frameon=False)
            mark_inputs(ax, changes, xlim[1], errors=errors)
        ax = axes[-1]
        ax.text(0.0 if len(pair) == 1 or pair[0] is None else -1.18, 1.32, rtitle, transform=ax.transAxes, fontsize=10,
                weight="bold")
    for ax in axes:
        ax.grid(True, alpha=0.4)
        ax.set_xlim(*xlim)
        ax.tick_params(labelsize=8)
    for ax in axes[-2:]:
        ax.set_xlabel("t [s]", fontsize=9)
    fig.suptitle(title + (" (red: error rows, no values)" if errors else ""), fontsize=12, y=1 - 0.15 / height)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def timing_figure(path, stats, c, t, xlim, marks, scene):
    report("drawing timing.png")
    _, sunits, _, _, s = read(stats, lambda n: n == "log_time" or n.startswith(("lateness_", "compute_")))
    lt = s.num("log_time")
    # the stats windows on the outputs' time axis: t at the same log time (where the log has both)
    if "log_time" in c and len(t) > 1:
        ts, xlabel = np.interp(lt, c.num("log_time"), t), "t [s] (each point: the stats window ending then)"
    else:
        ts, xlabel = lt, "log time [s] (each point: one stats window)"
    fig, axes = plt.subplots(2, 1, figsize=(13, 6.5), sharex=True)
    for ax, what in zip(axes, ("lateness", "compute")):
        for q, label in (("p50", "p50"), ("p99", "p99"), ("p999", "p99.9"), ("max", "max")):
            ax.plot(ts, s.num(f"{what}_{q}"), marker=".", label=label)
        ax.set_yscale("log")
        ax.set_ylabel(sunits.get(f"{what}_p50", "us"))
        ax.grid(True, which="both", alpha=0.4)
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=9, frameon=False)
        ax.set_title("wake-up lateness" if what == "lateness" else "compute time per tick", fontsize=10)
        mark_inputs(ax, marks[0], xlim[1])
    axes[-1].set_xlim(*xlim)
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(f"{scene}: loop timing")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main(argv):
    global PROGRESS
    args = [a for a in argv[1:] if a != "--progress"]
    PROGRESS = len(args) < len(argv) - 1
    out, steps = args[0], args[1]
    stats = args[2] if len(args) > 2 else ""
    made = []
    plotted = ("t", "log_time", "tau:", "stress:", ".m", ".f", ".sigma_")
    names, units, meta, comments, c = read(steps, lambda n: n.startswith(plotted[:4]) or any(p in n for p in plotted[4:]))
    report(f"read {steps} ({c.n} rows, {len(names)} columns)")
    t = c.num("t")
    xlim = (float(t[0]), float(t[-1])) if len(t) > 1 and t[-1] > t[0] else (0.0, 1.0)
    scene = comments[0].split("scene ", 1)[1].split(",")[0] if comments and "scene " in comments[0] else steps
    if scene.startswith("("):  # a log converted without --scene
        scene = "daemon log " + steps.rsplit("/", 2)[-2] if "/" in steps else "daemon log"
    marks = (input_changes(c, t), error_spans(c, t))
    torque_cols = [n for n in names if n.startswith("tau:") and nonzero(c.num(n))]
    stresses = [n for n in names if n.startswith("stress:")]
    wrenches = [(w, meta.get(w, ("", "", ""))) for w in dict.fromkeys(n.rsplit(".", 1)[0] for n in names if n.endswith(".fz"))]
    main_w = [w for w in wrenches if w[1][0] != "joint"]
    joints = [w for w in wrenches if w[1][0] == "joint"]
    # the joint reactions (the most panels) drawn by a second process on the second CPU, where there is one
    child = os.fork() if joints and hasattr(os, "fork") and (os.cpu_count() or 1) > 1 else None
    if child == 0:
        code = 1
        try:
            reactions_figure(out + "/reactions.png", f"{scene}: joint reactions", t, c, units, joints, marks, xlim)
            code = 0
        finally:
            os._exit(code)
    p = wrench_figure(out + "/wrenches.png", f"{scene}: wrenches (each component on its own scale)", t, c, units, main_w,
                      marks, torque_cols, stresses, xlim)
    made += [p] if p else []
    if stats:
        made.append(timing_figure(out + "/timing.png", stats, c, t, xlim, marks, scene))
    if joints and child is None:
        p = reactions_figure(out + "/reactions.png", f"{scene}: joint reactions", t, c, units, joints, marks, xlim)
        made += [p] if p else []
    elif joints:
        if os.waitpid(child, 0)[1] != 0:
            raise RuntimeError("drawing reactions.png failed")
        if os.path.exists(out + "/reactions.png"):
            made.append(out + "/reactions.png")
    report("done")
    for m in made:
        print("coopdyn log: wrote " + m)


if __name__ == "__main__":
    main(sys.argv)
