#!/usr/bin/env python3
"""Steady-turn sweep of config/scenes/four_wheel_car.yaml (docs/guide/wheels-and-vehicles.md, "Vehicles").

For a turn of radius R about a centre on the rear axle line, Ackermann steer angles, and speeds
from 0 up to past lift-off, writes each steady state (q, v) as a state file, runs `coopdyn eval`
on it and plots the four normal loads and the friction each wheel needs against the lateral
acceleration, with the textbook steady-state lines: lateral load transfer m a_y h / t split in
proportion to the axles' roll stiffness (60 / 40 here); and (docs/vehicle_turn_lateral.png) the
lateral force of each axle against the bicycle model's m a_y b / L, m a_y a / L.

    /usr/bin/python3 docs/plot_vehicle_turn.py build/bin/coopdyn docs [R]
"""
import json
import math
import os
import subprocess
import sys
import tempfile

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

coopdyn, outdir = sys.argv[1], sys.argv[2]
R = float(sys.argv[3]) if len(sys.argv) > 3 else 40.0
here = os.path.dirname(os.path.abspath(__file__))
scene_file = os.path.join(here, "..", "config", "scenes", "four_wheel_car.yaml")
lf, lr, t, h, r = 1.05, 1.61, 1.565, 0.65, 0.31
L = lf + lr
mc, mw, g, mu = 1430.0, 45.0, 9.81, 0.85
dl, dr = math.atan(L / (R - t / 2)), math.atan(L / (R + t / 2))

text = open(scene_file).read()
text = text.replace("name: fl_steer, pseudo: true, q: 0", "name: fl_steer, pseudo: true, q: %.17g" % dl)
text = text.replace("name: fr_steer, pseudo: true, q: 0", "name: fr_steer, pseudo: true, q: %.17g" % dr)
tmp = tempfile.mkdtemp()
scene = os.path.join(tmp, "car_turn.yaml")
open(scene, "w").write(text)

ay, normal, need = [], {k: [] for k in ("fl", "fr", "rl", "rr")}, {k: [] for k in ("fl", "fr", "rl", "rr")}
state = {k: [] for k in ("fl", "fr", "rl", "rr")}
lateral = {"front": [], "rear": []}  # chassis-y force of each axle's contacts, N
V = 0.0
while V <= 23.0 + 1e-9:
    Om = V / R
    q = [0, 0, 0.65, 1, 0, 0, 0, dl, dr, 0, 0, 0, 0]
    v = [0, 0, Om, Om * R, Om * lr, 0, 0, 0,
         Om * math.hypot(L, R - t / 2) / r, Om * math.hypot(L, R + t / 2) / r, Om * (R - t / 2) / r, Om * (R + t / 2) / r]
    sf = os.path.join(tmp, "state.json")
    json.dump({"q": q, "v": v, "tau": [0] * 12}, open(sf, "w"))
    out = subprocess.run([coopdyn, "eval", "--scene", scene, "--state", sf], capture_output=True, text=True, check=True)
    d = json.loads(out.stdout)
    ay.append(Om * Om * R / g)
    fy = {w["name"]: w["force"][1] for w in d["wrenches"] if w["name"] in ("fl", "fr", "rl", "rr")}
    lateral["front"].append(fy["fl"] * math.cos(dl) + fy["fr"] * math.cos(dr))
    lateral["rear"].append(fy["rl"] + fy["rr"])
    for c in d["contacts"]:
        normal[c["name"]].append(c["normal"])
        need[c["name"]].append(c["friction_needed"] if c["friction_needed"] >= 0 else float("nan"))
        state[c["name"]].append(c["state"])
    V += 0.25

M = mc + 4 * mw
Nf0, Nr0 = (mc * g * lr / L + 2 * mw * g) / 2, (mc * g * lf / L + 2 * mw * g) / 2
hcg = (mc * h + 4 * mw * r) / M
fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
colors = {"fl": "tab:blue", "fr": "tab:orange", "rl": "tab:green", "rr": "tab:red"}
for k in ("fl", "fr", "rl", "rr"):
    ax[0].plot(ay, normal[k], color=colors[k], lw=2, label="%s (coopdyn)" % k)
a = [x for x in ay]
for k, N0, share, sgn in (("fl", Nf0, 0.6, -1), ("fr", Nf0, 0.6, +1), ("rl", Nr0, 0.4, -1), ("rr", Nr0, 0.4, +1)):
    ax[0].plot(a, [N0 + sgn * share * M * x * g * hcg / t for x in a], color=colors[k], ls=":", lw=1.5)
ax[0].plot([], [], color="k", ls=":", label="textbook: m a_y h / t, 60/40 roll stiffness")
ax[0].axhline(0, color="k", lw=0.8)
ax[0].set_xlabel("lateral acceleration a_y / g (left turn, R = %g m)" % R)
ax[0].set_ylabel("normal force on the wheel, N")
ax[0].set_title("normal loads in a steady turn (inner wheels fl, rl)")
ax[0].legend(fontsize=9, loc="upper left")
ax[0].grid(alpha=0.3)
for k in ("fl", "fr", "rl", "rr"):
    ax[1].plot(ay, need[k], color=colors[k], lw=2, label=k)
ax[1].axhline(mu, color="k", ls="--", lw=1, label="mu = %.2f" % mu)
first_slip = next((ay[i] for i in range(len(ay)) if any(state[k][i] != "ok" for k in state)), None)
if first_slip is not None:
    ax[1].axvline(first_slip, color="tab:purple", lw=1, label="first sample reported 'slip': a_y = %.3f g" % first_slip)
ax[1].set_ylim(0, 2.0)
ax[1].set_xlabel("lateral acceleration a_y / g")
ax[1].set_ylabel("friction needed |f_t| / f_n")
ax[1].set_title("friction needed (compliance split, equal tire compliances)", fontsize=11)
ax[1].legend(fontsize=9, loc="upper left")
ax[1].grid(alpha=0.3)
fig.tight_layout()
path = os.path.join(outdir, "vehicle_turn.png")
fig.savefig(path, dpi=110)
print("wrote", path)

# lateral force per axle against the bicycle model (the whole car's m a_y split b / L, a / L)
fig, ax = plt.subplots(figsize=(6.5, 4.8))
ax.plot(ay, lateral["front"], color="tab:blue", lw=2, label="front axle (coopdyn, compliance rule)")
ax.plot(ay, lateral["rear"], color="tab:red", lw=2, label="rear axle (coopdyn, compliance rule)")
ax.plot(ay, [M * x * g * lr / L for x in ay], color="tab:blue", ls=":", lw=1.5, label="bicycle model m a_y b / L")
ax.plot(ay, [M * x * g * lf / L for x in ay], color="tab:red", ls=":", lw=1.5, label="bicycle model m a_y a / L")
ax.set_xlabel("lateral acceleration a_y / g (left turn, R = %g m)" % R)
ax.set_ylabel("lateral force on the axle (chassis y), N")
ax.set_title("steady turn: lateral force per axle", fontsize=11)
ax.legend(fontsize=9, loc="upper left")
ax.grid(alpha=0.3)
fig.tight_layout()
path = os.path.join(outdir, "vehicle_turn_lateral.png")
fig.savefig(path, dpi=110)
print("wrote", path)
i = min(range(len(ay)), key=lambda k: abs(ay[k] - 12.0 ** 2 / R / g))
print("at a_y = %.4f g: front %.2f N, rear %.2f N; bicycle %.2f N, %.2f N (front share %.4f, b / L %.4f)"
      % (ay[i], lateral["front"][i], lateral["rear"][i], M * ay[i] * g * lr / L, M * ay[i] * g * lf / L,
         lateral["front"][i] / (lateral["front"][i] + lateral["rear"][i]), lr / L))
