#!/usr/bin/python3
"""Estimate mode with joint friction and torque noise: the daemon's wrench from noisy measured
torques, its band (2 sigma + the friction bound), the simulator's true wrench, and the same replay
without joint-loss compensation. Made by bench/estimate_friction.sh (which runs the replay):

    python3 docs/plot_estimate_friction.py sim.csv comp/COOPDYN_OUTPUT.csv raw/COOPDYN_OUTPUT.csv out.png [WRENCH.C]

sim.csv is the simulator's run (the truth), comp/ the daemon's outputs with the joints' damping and
friction compensated (the default), raw/ with estimate.compensate_joint_losses false. Rows are
matched on the joint angles, which round-trip exactly through both CSVs.
"""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import coopdyn_csv  # docs/coopdyn_csv.py: the per-step CSV of either source

sim_path, comp_path, raw_path, png = sys.argv[1:5]
col = sys.argv[5] if len(sys.argv) > 5 else "arm1.ee.fz"
name, c = col.rsplit(".", 1)
sim = coopdyn_csv.read(sim_path).dicts()
joints = [k for k in sim[0] if k.startswith("q:")]
key = lambda r: tuple(float(r[j]) for j in joints)
by_q = {key(r): r for r in sim}


def matched(path):
    out, seen = [], set()
    for r in coopdyn_csv.read(path).dicts():
        if r["input"] != "state" or r["status"] == "error" or r["input_seq"] in seen:
            continue
        seen.add(r["input_seq"])
        s = by_q.get(key(r))
        if s is not None:
            out.append((float(s["t"]), r, s))
    out.sort(key=lambda x: x[0])
    return out


comp, raw = matched(comp_path), matched(raw_path)
t = np.array([x[0] for x in comp])
est = np.array([float(r[col]) for _, r, _ in comp])
true = np.array([float(s[col]) for _, _, s in comp])
sig = np.array([float(r[f"{name}.sigma_{c}"]) for _, r, _ in comp])
bnd = np.array([float(r[f"{name}.bound_{c}"]) for _, r, _ in comp])
rest = np.array([float(r[f"{name}.bound_{c}"]) > 0 for _, r, _ in comp])
t_raw = np.array([x[0] for x in raw])
est_raw = np.array([float(r[col]) for _, r, _ in raw])
true_raw = np.array([float(s[col]) for _, _, s in raw])
unit = "N*m" if c.startswith("m") else "N"

fig, ax = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
ax[0].fill_between(t, est - 2 * sig - bnd, est + 2 * sig + bnd, color="C0", alpha=0.25, lw=0,
                   label="band: 2 sigma (torque noise) + friction bound (joints at rest)")
ax[0].plot(t, true, color="k", lw=2.5, alpha=0.45, label=f"{col}, simulator (true)")
ax[0].plot(t, est, color="C0", lw=1, label=f"{col}, daemon estimate, friction compensated")
ax[0].plot(t_raw, est_raw, color="C3", lw=1, ls="--", label=f"{col}, daemon estimate, joint losses ignored")
ax[0].set_ylabel(f"{unit} (in the wrench's frame)")
ax[0].set_title(f"two_puma_friction: {len(t)} replayed states, torques with 0.5 N m noise")
ax[0].legend(fontsize=7, loc="best")
ax[1].fill_between(t, -2 * sig - bnd, 2 * sig + bnd, color="C0", alpha=0.25, lw=0, label="band (as above)")
ax[1].plot(t, est - true, color="C0", lw=1, label="estimate - true, compensated")
ax[1].plot(t_raw, est_raw - true_raw, color="C3", lw=1, ls="--", label="estimate - true, joint losses ignored")
ax[1].set_xlabel("t (s, the simulated trajectory; shaded wide where friction joints rest)")
ax[1].set_ylabel(unit)
ax[1].legend(fontsize=7, loc="best")
fig.tight_layout()
fig.savefig(png, dpi=110)
z = (est - true) / sig
inside = np.mean(np.abs(est - true) <= 2 * sig + bnd)
print(f"wrote {png}: {len(t)} states ({rest.sum()} with friction joints at rest); {col}: "
      f"rms (estimate - true) / sigma {np.sqrt(np.mean(z * z)):.3g}, "
      f"inside the band {100 * inside:.1f} %, uncompensated rms residual {np.sqrt(np.mean((est_raw - true_raw) ** 2)):.4g} {unit}, "
      f"median sigma {np.median(sig):.3g} {unit}, median bound at rest {np.median(bnd[rest]) if rest.any() else 0:.3g} {unit}")
