#!/usr/bin/env python3
"""Prints (and optionally plots) the wrenches of a coopdynd log by name.

    lcm-logger -f run.lcmlog &   # while coopdynd runs (lcm-logger -f overwrites run.lcmlog)
    python3 log_wrenches.py run.lcmlog --wrench arm1.ee --plot wrenches.png

One line per output_t and wrench: sim_time [s], the wrench's name, frame and who exerts it, then
mx my mz [N*m] and fx fy fz [N] (README "Forces everywhere": exerted by `by` on the part, at the
origin of `frame`, in its coordinates), numbers as the shortest text that reads back to the same
double. Needs the coopdyn Python package (PYTHONPATH=build/python, or installed); matplotlib only
for --plot.
"""
import argparse
import sys

try:
    from coopdyn import lcmlog
except ImportError:
    sys.exit("log_wrenches.py: the coopdyn Python package is not on the path: PYTHONPATH=build/python in the build "
             "tree, or PREFIX/lib/python3.X/site-packages after cmake --install (README: Python)")

COMPONENTS = ("mx", "my", "mz", "fx", "fy", "fz")
UNITS = ("N*m",) * 3 + ("N",) * 3


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    p.add_argument("log", help="an LCM log with coopdynd's output_t (lcm-logger)")
    p.add_argument("--channel", default="COOPDYN_OUTPUT", help="output_t channel (default: %(default)s)")
    p.add_argument("--wrench", action="append", metavar="NAME",
                   help="only this wrench (repeatable; default: all)")
    p.add_argument("--plot", metavar="FILE.png", help="also plot each component over time (matplotlib)")
    a = p.parse_args()

    rows = []  # (sim_time, name, wrench)
    names = None
    try:
        events = lcmlog.read(a.log, channel=a.channel)
        print("sim_time_s name frame by " + " ".join("%s_%s" % (c, u) for c, u in zip(COMPONENTS, UNITS)))
        for e in events:
            m = lcmlog.decode(e.data)
            if m is None or not hasattr(m, "wrench_names"):
                continue
            names = m.wrench_names
            for k, name in enumerate(m.wrench_names):
                if a.wrench and name not in a.wrench:
                    continue
                w = lcmlog.components(m.wrench[k])  # either output_t version (old logs: 6-lists)
                print("%r %s %s %s %s" % (m.sim_time, name, m.wrench_frames[k], m.wrench_by[k],
                                          " ".join(repr(x) for x in w)))
                rows.append((m.sim_time, name, w))
    except (OSError, lcmlog.LogError) as e:
        sys.exit("log_wrenches.py: %s" % e)
    if not rows:
        sys.exit("log_wrenches.py: %s: no output_t wrenches on %s%s" % (
            a.log, a.channel, "" if names is None or not a.wrench else " named " + ", ".join(a.wrench)
            + " (the log has " + ", ".join(names) + ")"))
    if a.plot:
        plot(rows, a.plot)


def plot(rows, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("log_wrenches.py: --plot needs matplotlib (Debian: apt install python3-matplotlib)")
    names = list(dict.fromkeys(r[1] for r in rows))
    fig, axes = plt.subplots(6, 1, sharex=True, figsize=(8, 11))
    for n in names:
        t = [r[0] for r in rows if r[1] == n]
        for c, ax in enumerate(axes):
            ax.plot(t, [r[2][c] for r in rows if r[1] == n], label=n)
    for c, ax in enumerate(axes):
        ax.set_ylabel("%s [%s]" % (COMPONENTS[c], UNITS[c]))
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel("sim_time [s]")
    fig.subplots_adjust(left=0.12, right=0.78, top=0.98, bottom=0.05, hspace=0.12)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    print("wrote %s" % path, file=sys.stderr)


if __name__ == "__main__":
    main()
