# The plots of `coopdyn log` (embedded in the coopdyn binary; also runs on its own):
#   python3 log_plot.py OUTDIR STEPS.csv [STATS.csv]
# STEPS.csv is a per-step CSV (docs/conventions.md): a `coopdyn sim --out` file or the output_t
# channel of `coopdyn log`; STATS.csv the loop_stats_t channel of a log ('' or absent: none).
# Writes OUTDIR/wrenches.png (the torques and inputs, then one panel per wrench component with its
# unit and, where the CSV carries the wrench's sigma (NAME.sigma_mx, ...), a +-sigma band around it,
# then the pseudo-joint stresses), OUTDIR/reactions.png (the joint reactions) and
# OUTDIR/timing.png, all on the same time axis t (s).
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def read(path):
    """-> (names, units by name, wrench meta {name: (kind, frame, by)}, comment lines, columns by name)"""
    comments, units, meta = [], {}, {}
    with open(path, newline="") as f:
        line = f.readline()
        while line.startswith("#"):
            comments.append(line[1:].strip())
            line = f.readline()
        names = line.rstrip("\r\n").split(",")
        rows = [r for r in csv.reader(f) if len(r) == len(names)]
    for c in comments:
        if c.startswith("units: "):
            units = dict(zip(names, c[len("units: "):].split(",")))
        elif c.startswith("wrench "):
            name, rest = c[len("wrench "):].split(": ", 1)
            fields = dict(p.split(" ", 1) for p in rest.split(", "))
            meta[name] = (fields.get("kind", ""), fields.get("frame", ""), fields.get("by", ""))
    cols = {n: [r[i] for r in rows] for i, n in enumerate(names)}
    return names, units, meta, comments, cols


def numeric(cells):
    return np.array([float(x) if x not in ("", "nan") else np.nan for x in cells])


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


def mark_inputs(ax, changes, t_end, label=False):
    for i, (t0, what) in enumerate(changes):
        t1 = changes[i + 1][0] if i + 1 < len(changes) else t_end
        if what not in ("command", "state"):  # no input: shade where the daemon ran without one
            ax.axvspan(t0, t1, color="0.85", zorder=0)
        ax.axvline(t0, color="0.5", lw=0.8, ls=":")
        if label:
            ax.annotate(what.replace("_", " "), (t0, 0.97 - 0.16 * (i % 2)), xycoords=("data", "axes fraction"), xytext=(3, 0),
                        textcoords="offset points", va="top", ha="left", fontsize=8, color="0.2")


BAND_COLOR, BAND_ALPHA = "tab:orange", 0.3


def sigma_column(c):
    """The column of component c's standard deviation (NAME.mx -> NAME.sigma_mx)."""
    name, comp = c.rsplit(".", 1)
    return f"{name}.sigma_{comp}"


def sigma_band(ax, t, y, cols, c):
    """Draws y +- sigma where the CSV carries component c's sigma (nonzero somewhere); True if drawn."""
    sc = sigma_column(c)
    if sc not in cols:
        return False
    s = numeric(cols[sc])
    if not np.any(s > 0):
        return False
    ax.fill_between(t, y - s, y + s, color=BAND_COLOR, alpha=BAND_ALPHA, lw=0, zorder=1)
    return True


def wrench_figure(path, title, t, cols, units, wrenches, changes, torque_cols, stresses, xlim):
    comps = (("mx", "my", "mz"), ("fx", "fy", "fz"))
    rows = []  # (title, [column or None] x 3)
    for name, (kind, frame, by) in wrenches:
        for what, cs in zip(("moment", "force"), comps):
            cc = [name + "." + c for c in cs]
            if any(np.any(numeric(cols[c]) != 0) for c in cc):  # all-zero rows (a wheel's moments) left out
                rows.append((describe(name, kind, frame, by) + f": {what}", cc))
    top = 1 if torque_cols else 0
    bottom = 1 if stresses else 0
    n = top + len(rows) + bottom
    if n == 0:
        return None
    height = 1.3 + 2.1 * n
    fig = plt.figure(figsize=(13, height))
    gs = fig.add_gridspec(n, 3, hspace=0.75, wspace=0.28, top=1 - 1.25 / height, bottom=0.45 / height)
    ax0 = None
    axes = []

    def wide(r):
        ax = fig.add_subplot(gs[r, :], sharex=ax0)
        axes.append(ax)
        return ax

    if top:
        ax0 = wide(0)
        for c in torque_cols:
            ax0.plot(t, numeric(cols[c]), lw=1.2, label=c[4:])
        ax0.set_title("applied torques tau (nonzero joints)" + ("; shaded: no input, dotted: the input changes" if changes else ""),
                      fontsize=10)
        ax0.set_ylabel(units.get(torque_cols[0], ""))
        ax0.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
        mark_inputs(ax0, changes, xlim[1], label=True)
    for r, (rtitle, cc) in enumerate(rows):
        for k, c in enumerate(cc):
            ax = fig.add_subplot(gs[top + r, k], sharex=ax0)
            if ax0 is None:
                ax0 = ax
            axes.append(ax)
            y = numeric(cols[c])
            ax.plot(t, y, lw=1.2)
            band = sigma_band(ax, t, y, cols, c)
            ax.set_title(c.rsplit(".", 1)[1] + f" [{units.get(c, '')}]" + (" (band: +-sigma)" if band else ""), fontsize=10)
            ax.ticklabel_format(axis="y", useOffset=False)
            mark_inputs(ax, changes, xlim[1])
            if k == 0:
                ax.text(0.0, 1.32, rtitle, transform=ax.transAxes, fontsize=10, weight="bold")
    if stresses:
        ax = wide(n - 1)
        for c in stresses:
            ax.plot(t, numeric(cols[c]), lw=1.2, label=f"{c[7:]} [{units.get(c, '')}]")
        ax.set_title("pseudo-joint stresses", fontsize=10)
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
        mark_inputs(ax, changes, xlim[1])
    for ax in axes:
        ax.grid(True, alpha=0.4)
        ax.set_xlim(*xlim)
        ax.tick_params(labelsize=8)
    for ax in axes[-3:]:
        ax.set_xlabel("t [s]", fontsize=9)
    fig.suptitle(title, fontsize=12, y=1 - 0.15 / height)
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return path


def main(argv):
    out, steps = argv[1], argv[2]
    stats = argv[3] if len(argv) > 3 else ""
    made = []
    names, units, meta, comments, c = read(steps)
    t = numeric(c["t"])
    xlim = (float(t[0]), float(t[-1])) if len(t) > 1 and t[-1] > t[0] else (0.0, 1.0)
    scene = comments[0].split("scene ", 1)[1].split(",")[0] if comments and "scene " in comments[0] else steps
    if scene.startswith("("):  # a log converted without --scene
        scene = "daemon log " + steps.rsplit("/", 2)[-2] if "/" in steps else "daemon log"
    changes = input_changes(c, t)
    torque_cols = [n for n in names if n.startswith("tau:") and np.any(numeric(c[n]) != 0)]
    stresses = [n for n in names if n.startswith("stress:")]
    wrenches = [(w, meta.get(w, ("", "", ""))) for w in dict.fromkeys(n.rsplit(".", 1)[0] for n in names if n.endswith(".fz"))]
    main_w = [w for w in wrenches if w[1][0] != "joint"]
    joints = [w for w in wrenches if w[1][0] == "joint"]
    p = wrench_figure(out + "/wrenches.png", f"{scene}: wrenches (each component on its own scale)", t, c, units, main_w,
                      changes, torque_cols, stresses, xlim)
    made += [p] if p else []
    if joints:
        p = wrench_figure(out + "/reactions.png", f"{scene}: joint reactions", t, c, units, joints, changes, [], [], xlim)
        made += [p] if p else []
    if stats:
        _, sunits, _, _, s = read(stats)
        lt = numeric(s["log_time"])
        # the stats windows on the outputs' time axis: t at the same log time (where the log has both)
        if "log_time" in c and len(t) > 1:
            ts, xlabel = np.interp(lt, numeric(c["log_time"]), t), "t [s] (each point: the stats window ending then)"
        else:
            ts, xlabel = lt, "log time [s] (each point: one stats window)"
        fig, axes = plt.subplots(2, 1, figsize=(13, 6.5), sharex=True)
        for ax, what in zip(axes, ("lateness", "compute")):
            for q, label in (("p50", "p50"), ("p99", "p99"), ("p999", "p99.9"), ("max", "max")):
                ax.plot(ts, numeric(s[f"{what}_{q}"]), marker=".", label=label)
            ax.set_yscale("log")
            ax.set_ylabel(sunits.get(f"{what}_p50", "us"))
            ax.grid(True, which="both", alpha=0.4)
            ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=9, frameon=False)
            ax.set_title("wake-up lateness" if what == "lateness" else "compute time per tick", fontsize=10)
            mark_inputs(ax, changes, xlim[1])
        axes[-1].set_xlim(*xlim)
        axes[-1].set_xlabel(xlabel)
        fig.suptitle(f"{scene}: loop timing")
        fig.tight_layout()
        fig.savefig(out + "/timing.png", dpi=80)
        plt.close(fig)
        made.append(out + "/timing.png")
    for m in made:
        print("coopdyn log: wrote " + m)


if __name__ == "__main__":
    main(sys.argv)
