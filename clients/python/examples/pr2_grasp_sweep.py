#!/usr/bin/env python3
"""PR2 holding its box (config/scenes/pr2_box.yaml): the wrench at each hand as the grasps move up and
down the box's sides, the arms holding the box still (coopdynd's safe torque `hold`).

    PYTHONPATH=build/python python3 clients/python/examples/pr2_grasp_sweep.py [--plot grasp_sweep.png]

For each grasp height h (m, along the box's z axis, 0 at its centre) the scene is the shipped one with
both grasp frames moved by h: the loader closes the loop again (the box's pose follows the grippers),
Scene.evaluate(hold=True) gives the wrenches with the holding torques applied. Prints one row per
height (h, then each hand's [mx my mz] N*m and [fx fy fz] N in its grasp frame) and with --plot draws
the force along gravity and the moments (needs python3-matplotlib).
"""
import argparse
import os
import re
import sys

import numpy as np

import coopdyn

SCENES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "config", "scenes")


def scene_at(text, h):
    """The scene's text with both grasp frames moved by h along the box's z axis."""
    return re.sub(r"(\{name: box\.(left|right), body: box, xyz: \[0, -?0\.2245), 0\]", r"\1, %r]" % h, text)


def sweep(path, heights):
    text = open(path).read()
    cwd = os.getcwd()
    os.chdir(os.path.dirname(os.path.abspath(path)))  # the scene names its robot relative to itself
    try:
        rows = []
        for h in heights:
            s = coopdyn.load_scene(scene_at(text, h))
            ev = s.evaluate(hold=True)
            rows.append((h, ev.status, {n: ev.wrenches[n] for n in s.wrench_names},
                         {n: ev.wrench_frames[n] for n in s.wrench_names}))
        return s.wrench_names, rows
    finally:
        os.chdir(cwd)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=os.path.join(SCENES, "pr2_box.yaml"))
    p.add_argument("--from", dest="lo", type=float, default=-0.10, help="lowest grasp height, m (default -0.10)")
    p.add_argument("--to", dest="hi", type=float, default=0.10, help="highest grasp height, m (default 0.10)")
    p.add_argument("--steps", type=int, default=21)
    p.add_argument("--plot", help="write a PNG of the sweep")
    a = p.parse_args()
    names, rows = sweep(a.scene, np.linspace(a.lo, a.hi, a.steps))
    hands = [n for n in names if n in ("left_hand", "right_hand")] or names[:2]
    print("h_m,status," + ",".join("%s.%s" % (n, c) for n in hands for c in ("mx", "my", "mz", "fx", "fy", "fz")))
    for h, status, w, _ in rows:
        print("%r,%s," % (float(h), status) + ",".join(repr(float(x)) for n in hands for x in w[n]))
    if a.plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            sys.exit("pr2_grasp_sweep.py: --plot needs matplotlib (Debian: python3-matplotlib)")
        hs = np.array([r[0] for r in rows])
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for n in hands:
            # force along gravity: the grasp frame's force rotated into the world, z component
            fz = [(r[3][n][:3, :3] @ r[2][n][3:])[2] for r in rows]
            mm = [np.linalg.norm(r[2][n][:3]) for r in rows]
            ax[0].plot(hs * 100, fz, marker="o", label=n)
            ax[1].plot(hs * 100, mm, marker="o", label=n)
        ax[0].axhline(-3.0 * 9.81 / 2, color="gray", ls="--", label="half the box's weight (3 kg)")
        ax[0].set(xlabel="grasp height on the box (cm)", ylabel="force on the hand, world z (N)",
                  title="Vertical force at each grasp")
        ax[1].set(xlabel="grasp height on the box (cm)", ylabel="|moment| at the grasp (N·m)",
                  title="Moment at each grasp")
        for x in ax:
            x.grid(True, alpha=0.3)
            x.legend()
        fig.suptitle("PR2 holding its 3 kg box (pr2_box, hold torques): wrenches vs grasp height")
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
        print("wrote %s" % a.plot, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
