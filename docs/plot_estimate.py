#!/usr/bin/python3
"""Estimation from joint measurements alone: the daemon's wrenches from the arms' joints only,
against the simulator's at the same states, and the closure residual of each fit.

    build/bin/coopdyn sim --scene config/scenes/two_puma_load.yaml --duration 2 --dt 0.001 \
        --torque arm1.q1:pulse:1.0:0.5:1.0 --out sim.csv
    lcm-logger --lcm-url="udpm://239.255.76.67:7667?ttl=0" run.lcmlog &
    build/bin/coopdynd --scene config/scenes/two_puma_load.yaml --mode estimate --duration 5 &
    build/bin/coopdyn send --scene config/scenes/two_puma_load.yaml --states sim.csv --rate 200 --joints-only
    build/bin/coopdyn log --in run.lcmlog --out logcsv --no-plot
    python3 docs/plot_estimate.py sim.csv logcsv/COOPDYN_OUTPUT.csv estimate.png

The daemon saw no load pose or twist: it fitted them (state_fit.h). Rows are matched on the joint
angles, which round-trip exactly through both CSVs.
"""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import coopdyn_csv  # docs/coopdyn_csv.py: the per-step CSV of either source

sim_path, out_path, png = sys.argv[1], sys.argv[2], sys.argv[3]
sim = coopdyn_csv.read(sim_path).dicts()
joints = [k for k in sim[0] if k.startswith("q:arm")]
key = lambda r: tuple(float(r[j]) for j in joints)
by_q = {key(r): r for r in sim}
wrench_cols = [k for k in sim[0] if k.split(".")[-1] in ("mx", "my", "mz", "fx", "fy", "fz") and (".ee." in k or ".base." in k)]
t, est1, sim1, est2, sim2, diff, clo_p, clo_r, clo_v = [], [], [], [], [], [], [], [], []
seen = set()
for r in coopdyn_csv.read(out_path).dicts():
    if r["input"] != "state" or r["status"] == "error" or r["input_seq"] in seen:
        continue
    seen.add(r["input_seq"])
    s = by_q.get(key(r))
    if s is None:
        continue
    t.append(float(s["t"]))
    est1.append(float(r["arm1.ee.fz"])); sim1.append(float(s["arm1.ee.fz"]))
    est2.append(float(r["arm2.ee.fz"])); sim2.append(float(s["arm2.ee.fz"]))
    diff.append(max(abs(float(r[c]) - float(s[c])) / (1 + abs(float(s[c]))) for c in wrench_cols))
    clo_p.append(float(r["closure_position"])); clo_r.append(float(r["closure_orientation"]))
    clo_v.append(float(r["closure_linear_velocity"]))
o = np.argsort(t)
A = lambda x: np.array(x)[o]
t = A(t)
fig, ax = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
ax[0].plot(t, A(sim1), lw=3, alpha=0.35, label="arm1.ee fz, simulator (full state)")
ax[0].plot(t, A(est1), lw=1, label="arm1.ee fz, daemon from the joints only")
ax[0].plot(t, A(sim2), lw=3, alpha=0.35, label="arm2.ee fz, simulator")
ax[0].plot(t, A(est2), lw=1, label="arm2.ee fz, daemon from the joints only")
ax[0].set_ylabel("N (in the end-effector frame)")
ax[0].set_title(f"two_puma_load: {len(t)} replayed states, the load's pose and twist fitted from 12 joints")
ax[0].legend(fontsize=8, loc="best")
floor = 1e-17
ax[1].semilogy(t, np.maximum(A(diff), floor), lw=0.8, label="max |daemon - simulator| / (1 + |simulator|), every ee and base component")
ax[1].semilogy(t, np.maximum(A(clo_p), floor), lw=0.8, label="closure residual, position (m)")
ax[1].semilogy(t, np.maximum(A(clo_r), floor), lw=0.8, label="closure residual, orientation (rad)")
ax[1].semilogy(t, np.maximum(A(clo_v), floor), lw=0.8, label="closure residual, velocity (m/s)")
ax[1].set_xlabel("t (s, the simulated trajectory)")
ax[1].legend(fontsize=7, loc="upper left")
fig.tight_layout()
fig.savefig(png, dpi=110)
print(f"wrote {png}: {len(t)} states, max relative wrench difference {max(diff):.3g}, "
      f"max closure {max(clo_p):.3g} m / {max(clo_r):.3g} rad / {max(clo_v):.3g} m/s")
