#!/usr/bin/python3
"""The reference controller's run: the load along its circle and the squeeze at its set-point.

    build/bin/coopdynd --scene config/scenes/two_puma_load.yaml --duration 10 &
    build/bin/coopdyn track --scene config/scenes/two_puma_load.yaml --duration 8 --out track.csv
    python3 docs/plot_track.py track.csv track.png

track.csv is written by `coopdyn track --out` ('#' lines with the scene and the units, then one row
per command: the reference and the load's position in the world, m; the pose errors, m and rad; the
squeeze the daemon's end-effector wrenches give and its set-point, N; in_sync = 1 when the output was stepped under one of the controller's
last 3 commands, not an older one or the daemon's safe torque after a stall).
"""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import coopdyn_csv  # docs/coopdyn_csv.py: the '#' lines, then the header

src, out = sys.argv[1], sys.argv[2]
col = coopdyn_csv.read(src).col
t = col("t")
fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True, gridspec_kw={"height_ratios": [2, 1.3, 2]})
for k, c in (("y", "tab:blue"), ("z", "tab:orange")):
    ax[0].plot(t, col("ref_" + k), color=c, lw=3, alpha=0.35, label=f"reference {k}")
    ax[0].plot(t, col(k), color=c, lw=1, label=f"load {k} (daemon)")
ax[0].set_ylabel("m")
ax[0].set_title("two_puma_load under coopdyn track: a 5 cm circle in the y-z plane, 4 s a lap")
ax[0].legend(loc="upper left", ncol=2, fontsize=8)
ax[1].semilogy(t, np.maximum(col("position_error"), 1e-9), lw=0.8, label="position error (m)")
ax[1].semilogy(t, np.maximum(col("orientation_error"), 1e-9), lw=0.8, label="orientation error (rad)")
ax[1].set_ylabel("error")
ax[1].legend(loc="upper right", fontsize=8)
ax[2].plot(t, col("squeeze_set"), "k--", lw=1, label="set-point (ramped in over the first second)")
ax[2].plot(t, col("squeeze"), lw=1, label="squeeze from the daemon's end-effector wrenches")
ax[2].set_ylabel("N")
ax[2].set_xlabel("t (s, the daemon's simulated time)")
ax[2].legend(loc="lower right", fontsize=8)
late = t > 1.5
ax[2].set_title(f"after 1.5 s: position error max {col('position_error')[late].max():.2g} m, "
                f"squeeze max |s - set| {np.abs(col('squeeze') - col('squeeze_set'))[late].max():.2g} N", fontsize=9)
fig.tight_layout()
fig.savefig(out, dpi=110)
print("wrote", out)
