#!/usr/bin/python3
"""The squeeze between the two arms of two_puma_load, from coopdyn's end-effector wrenches.

    build/bin/coopdyn eval --scene config/scenes/two_puma_load.yaml > eval.json
    build/bin/coopdyn sim --scene config/scenes/two_puma_load.yaml --duration 2 --dt 0.001 \
        --torque arm1.q1:pulse:1.0:0.5:1.0 --out sim.csv
    python3 docs/plot_squeeze.py eval.json sim.csv squeeze.png

ARM.ee is the load's wrench on the end-effector, in the end-effector frame. Each arm's force on
the load is its negative; both are taken into the load frame with the grasp rotations R_L_EE
(constant: the grasps are rigid; read off the eval at the initial state). With u the unit vector
from arm 1's grasp to arm 2's, the squeeze (internal force) is s = (f1 - f2) . u / 2, positive when
the arms press the load between them, and the net force along u is (f1 + f2) . u.
"""
import json, sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import coopdyn_csv  # docs/coopdyn_csv.py: the per-step CSV of either source

ev_path, csv_path, out = sys.argv[1], sys.argv[2], sys.argv[3]
ev = json.load(open(ev_path))
q_names = ev["coordinates"]["q"]
q0 = dict(zip(q_names, ev["q"]))

def load_rotation(qw, qx, qy, qz):
    w, x, y, z = qw, qx, qy, qz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

R_WL0 = load_rotation(q0["load.qw"], q0["load.qx"], q0["load.qy"], q0["load.qz"])
p_WL0 = np.array([q0["load.x"], q0["load.y"], q0["load.z"]])
grasp = {}
for w in ev["wrenches"]:
    if w["kind"] == "end_effector":
        arm = w["name"].split(".")[0]
        R_WE = np.array(w["frame_W"]["R"])
        grasp[arm] = (R_WL0.T @ R_WE, R_WL0.T @ (np.array(w["frame_W"]["p"]) - p_WL0))
u = grasp["arm2"][1] - grasp["arm1"][1]
u /= np.linalg.norm(u)

t, s, net, tau = [], [], [], []
for row in coopdyn_csv.read(csv_path).dicts():
    fL = {}
    for arm, (R_LE, _) in grasp.items():
        f_ee = np.array([float(row[f"{arm}.ee.{k}"]) for k in ("fx", "fy", "fz")])
        fL[arm] = -(R_LE @ f_ee)  # the arm's force on the load, load frame
    t.append(float(row["t"]))
    s.append(0.5 * (fL["arm1"] - fL["arm2"]) @ u)
    net.append((fL["arm1"] + fL["arm2"]) @ u)
    tau.append(float(row["tau:arm1.q1"]))

fig, ax = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
ax[0].plot(t, s, label="squeeze (f1 - f2).u / 2")
ax[0].plot(t, net, "--", label="net force along u, (f1 + f2).u")
ax[0].axhline(0, color="k", lw=0.5)
ax[0].set_ylabel("N")
ax[0].set_title("two_puma_load: internal force between the grasps (u: grasp 1 to grasp 2)")
ax[0].legend(loc="upper right")
ax[0].grid(True)
ax[1].plot(t, tau, color="C2")
ax[1].set_ylabel("tau arm1.q1 [N*m]")
ax[1].set_xlabel("simulation time [s]")
ax[1].grid(True)
fig.tight_layout()
fig.savefig(out, dpi=90)
print(f"wrote {out}: squeeze at t=0 {s[0]:.6g} N, range {min(s):.4g} .. {max(s):.4g} N")
