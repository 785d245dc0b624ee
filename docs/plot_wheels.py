#!/usr/bin/python3
"""Plots the contact wrenches of the two-wheeled vehicle like the paper's Fig. 12-14.

Input: a per-step CSV of config/scenes/two_wheel_vehicle.yaml (docs/conventions.md): the one of
`coopdyn sim --out`, or the COOPDYN_OUTPUT.csv that `coopdyn log` makes of a daemon's log (time is
then the daemon's t). The figures in docs/ were made with (from the repository root):

  build/bin/coopdyn sim --scene config/scenes/two_wheel_vehicle.yaml --duration 2 --dt 0.001 \
      --torque left_spin:pulse:1.0:0:0.5 --out /tmp/wheels.csv
  /usr/bin/python3 docs/plot_wheels.py /tmp/wheels.csv docs

Writes OUTDIR/wheels_input.png (Fig. 12: the drive torques), OUTDIR/wheels_left.png (Fig. 13) and
OUTDIR/wheels_right.png (Fig. 14): per wheel the moments mx, my, mz and forces fx, fy, fz that the
ground exerts on the wheel at its contact point, in its contact frame (x heading, y lateral left,
z up), against time. Needs matplotlib (Debian: apt-get install python3-matplotlib).
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import coopdyn_csv  # noqa: E402  (docs/coopdyn_csv.py, beside this script)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_wheels.py SIM.csv OUTDIR")
    path, outdir = sys.argv[1], sys.argv[2]
    run = coopdyn_csv.read(path)
    t = run.col("t")
    col = run.col
    on = t[col("tau:left_spin") != 0]
    pulse = f"{on[0]:g}-{t[t > on[-1]][0]:g} s" if len(on) and (t > on[-1]).any() else "none"

    fig, axes = plt.subplots(2, 1, figsize=(6, 4), sharex=True)
    for ax, j in zip(axes, ["left_spin", "right_spin"]):
        ax.plot(t, col("tau:" + j), color="k")
        ax.set_ylabel(j.replace("_spin", "") + " torque [N m]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"Inputs (paper Fig. 12): 1 N m on the left wheel, {pulse}")
    fig.tight_layout()
    fig.savefig(f"{outdir}/wheels_input.png", dpi=110)

    labels = {
        "mx": "moment x [N m]", "my": "moment y [N m]", "mz": "moment z [N m]",
        "fx": "force x (heading) [N]", "fy": "force y (lateral) [N]", "fz": "force z (normal) [N]",
    }
    for wheel, fig_no in [("left", 13), ("right", 14)]:
        fig, axes = plt.subplots(6, 1, figsize=(6, 10), sharex=True)
        for ax, c in zip(axes, ["mx", "my", "mz", "fx", "fy", "fz"]):
            ax.plot(t, col(f"{wheel}.{c}"), color="b")
            ax.set_ylabel(labels[c], fontsize=8)
            ax.ticklabel_format(axis="y", useOffset=False)
            if c == "fz":  # the paper's axis spans 0.01 N (34.325-34.335): the same span here
                ax.set_ylim(34.330, 34.340)
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel("time [s]")
        frame = run.wrenches.get(wheel, {}).get("frame", wheel + ".contact")
        fig.suptitle(f"{wheel.capitalize()} wheel: the ground on the wheel at its contact point,\n"
                     f"in its contact frame {frame} (paper Fig. {fig_no})", fontsize=10)
        fig.tight_layout()
        fig.savefig(f"{outdir}/wheels_{wheel}.png", dpi=110)


if __name__ == "__main__":
    main()
