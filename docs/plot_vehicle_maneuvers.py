#!/usr/bin/env python3
"""Manoeuvres of config/scenes/four_wheel_car.yaml with coopdyn sim (docs/guide/wheels-and-vehicles.md, "Vehicles").

1. Straight-line acceleration and braking (docs/vehicle_accel_brake.png): from rest, a drive torque
   on the rear wheels rising 0 -> 1200 N*m over 2 s; from 30 m/s, a braking torque on all four
   wheels rising at 1500 N*m/s for 1.6 s. The axle loads against the textbook longitudinal load
   transfer m a h / L (the car's mass at its CG height), and the moments the report turns a wheel
   to slip and to lift_off.
2. A step steer at speed (docs/vehicle_step_steer.png): at 15 m/s straight ahead, the steer
   commanded from t = 0.2 s to the Ackermann angles of a 30 m turn in 0.2 s (--steer FILE.csv, the
   two angles Ackermann-consistent at every millisecond, as a rigid no-slip car needs). The yaw rate against the
   kinematic yaw rate of the steer angle the front-left wheel has reached, and each wheel's friction
   utilisation, with the moment the inner wheels' utilisation reaches 1.

    /usr/bin/python3 docs/plot_vehicle_maneuvers.py build/bin/coopdyn docs
"""
import csv
import math
import os
import subprocess
import sys
import tempfile

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

coopdyn, outdir = sys.argv[1], sys.argv[2]
here = os.path.dirname(os.path.abspath(__file__))
scene_file = os.path.join(here, "..", "config", "scenes", "four_wheel_car.yaml")
lf, lr, t, h, r = 1.05, 1.61, 1.565, 0.65, 0.31
L = lf + lr
mc, mw, g, mu, I = 1430.0, 45.0, 9.81, 0.85, 1.2
M = mc + 4 * mw
hcg = (mc * h + 4 * mw * r) / M
Nf0, Nr0 = (mc * g * lr / L + 2 * mw * g), (mc * g * lf / L + 2 * mw * g)  # per axle
tmp = tempfile.mkdtemp()
base = open(scene_file).read()


def scene_at_speed(V, name):
    """The car scene with every body moving straight ahead at V (wheels rolling)."""
    text = base.replace("joint: {type: floating, name: chassis, q: {xyz: [0, 0, 0.65]}}",
                        "joint: {type: floating, name: chassis, q: {xyz: [0, 0, 0.65]}, v: [0, 0, 0, %.17g, 0, 0]}" % V)
    for w in ("fl", "fr", "rl", "rr"):
        text = text.replace("name: %s_spin}" % w, "name: %s_spin, v: %.17g}" % (w, V / r))
    path = os.path.join(tmp, name)
    open(path, "w").write(text)
    return path


def sim(scene, args, name):
    out = os.path.join(tmp, name)
    cmd = [coopdyn, "sim", "--scene", scene, "--out", out] + args
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("coopdyn sim failed: " + " ".join(cmd) + "\n" + p.stderr)
    rows = list(csv.DictReader(open(out)))
    return rows, p.stderr


def col(rows, key, f=float):
    return [f(x[key]) for x in rows]


def first(rows, pred):
    return next((i for i, x in enumerate(rows) if pred(x)), None)


# ---- 1. acceleration and braking ----
acc, acc_log = sim(scene_file, ["--duration", "2", "--dt", "0.001", "--every", "10",
                                "--torque", "rl_spin:ramp:1200:0:2", "--torque", "rr_spin:ramp:1200:0:2"], "accel.csv")
brk, brk_log = sim(scene_at_speed(30.0, "car30.yaml"),
                   ["--duration", "1.6", "--dt", "0.001", "--every", "10"] +
                   sum((["--torque", "%s_spin:ramp:-2400:0:1.6" % w] for w in ("fl", "fr", "rl", "rr")), []), "brake.csv")
fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
for rows, label, marker in ((acc, "accelerating (rear drive)", "o"), (brk, "braking (four wheels)", "s")):
    a = col(rows, "vdot:chassis.vx")
    front = [float(x["fl.fz"]) + float(x["fr.fz"]) for x in rows]
    rear = [float(x["rl.fz"]) + float(x["rr.fz"]) for x in rows]
    ax[0].plot([x / g for x in a], front, marker, ms=3, color="tab:blue", label="front axle, " + label)
    ax[0].plot([x / g for x in a], rear, marker, ms=3, color="tab:red", label="rear axle, " + label)
amin = min(col(brk, "vdot:chassis.vx")) / g
amax = max(col(acc, "vdot:chassis.vx")) / g
grid = [amin + (amax - amin) * k / 100 for k in range(101)]
ax[0].plot(grid, [Nf0 - M * x * g * hcg / L for x in grid], "k:", lw=1.5, label="textbook N0 -/+ m a h / L")
ax[0].plot(grid, [Nr0 + M * x * g * hcg / L for x in grid], "k:", lw=1.5)
ax[0].axhline(0, color="k", lw=0.8)
ax[0].set_xlabel("longitudinal acceleration a / g")
ax[0].set_ylabel("axle normal load, N")
ax[0].set_title("longitudinal load transfer (%.0f kg, h %.3f m, L %.2f m)" % (M, hcg, L))
ax[0].grid(alpha=0.3)
ax[0].legend(fontsize=8, loc="upper center")
for rows, label, ls in ((acc, "accelerating", "-"), (brk, "braking", "--")):
    tt = col(rows, "t")
    for w, c in (("fl", "tab:blue"), ("rl", "tab:red")):
        u = [float(x[w + ".utilisation"]) if float(x[w + ".utilisation"]) >= 0 else float("nan") for x in rows]
        ax[1].plot(tt, u, ls, color=c, label="%s, %s" % (w, label))
    for w in ("fl", "rl"):
        for state, m in (("slip", "v"), ("lift_off", "x")):
            i = first(rows, lambda x: x[w + ".contact"] == state)
            if i is not None:
                u = float(rows[i][w + ".utilisation"])
                ax[1].plot(tt[i], u if u >= 0 else 0, m, color="k", ms=8)
                ax[1].annotate("%s %s t=%.2f s" % (w, state, tt[i]), (tt[i], u if u >= 0 else 0), fontsize=8,
                               xytext=(4, -12 if state == "slip" else 6), textcoords="offset points")
ax[1].axhline(1.0, color="k", ls=":", lw=1)
ax[1].set_ylim(0, 1.6)
ax[1].set_xlabel("time, s (torque ramps: drive 600 N*m/s on rl, rr; brake 1500 N*m/s on all four)")
ax[1].set_ylabel("friction utilisation |f_t| / (mu N)")
ax[1].set_title("when the road stops supplying the no-slip forces")
ax[1].grid(alpha=0.3)
ax[1].legend(fontsize=8, loc="upper left")
fig.tight_layout()
fig.savefig(os.path.join(outdir, "vehicle_accel_brake.png"), dpi=110)

# the numbers docs/guide/wheels-and-vehicles.md quotes
def fit_slope(rows, key):
    a = col(rows, "vdot:chassis.vx")
    y = [float(x[key + "l.fz"]) + float(x[key + "r.fz"]) for x in rows]
    n = len(a)
    ma, my = sum(a) / n, sum(y) / n
    return sum((a[i] - ma) * (y[i] - my) for i in range(n)) / sum((x - ma) ** 2 for x in a)
for rows, label in ((acc, "accelerating"), (brk, "braking")):
    print("%s: rear axle load +%.3f N per m/s^2 (textbook m h / L %.3f, with the wheels' spin %.3f)"
          % (label, fit_slope(rows, "r"), M * hcg / L, (mc * h + 4 * mw * r + 4 * I / r) / L))
    for w in ("fl", "rl"):
        for state in ("slip", "lift_off"):
            i = first(rows, lambda x: x[w + ".contact"] == state)
            if i is not None:
                print("  %s %s from t = %s s, a = %.3f m/s^2" % (w, state, rows[i]["t"], float(rows[i]["vdot:chassis.vx"])))

# ---- 2. step steer at speed ----
V, R = 15.0, 30.0
dl, dr = math.atan(L / (R - t / 2)), math.atan(L / (R + t / 2))
# the steer as a fast ramp of the path curvature k (0 -> 1 / R over 0.2 s from t = 0.2 s), the two
# angles Ackermann-consistent at every millisecond: tan(d) = L k / (1 -/+ k t / 2)
ramp = os.path.join(tmp, "steer.csv")
with open(ramp, "w") as f:
    f.write("t,fl_steer,fr_steer\n")
    for i in range(0, 1501):
        ti = i * 1e-3
        k = min(max((ti - 0.2) / 0.2, 0.0), 1.0) / R
        f.write("%.17g,%.17g,%.17g\n" % (ti, math.atan(L * k / (1 - k * t / 2)), math.atan(L * k / (1 + k * t / 2))))
st, st_log = sim(scene_at_speed(V, "car15.yaml"),
                 ["--duration", "1.5", "--dt", "0.001", "--every", "5", "--steer", ramp], "steer.csv")
tt = col(st, "t")
yaw = col(st, "v:chassis.wz")
vx = col(st, "v:chassis.vx")
d = col(st, "q:fl_steer")
w2 = t / 2
kin = [vx[i] * math.tan(d[i]) / (L + w2 * math.tan(d[i])) for i in range(len(tt))]  # fl wheel's lateral no-slip
fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
ax[0].plot(tt, yaw, color="tab:blue", lw=2, label="yaw rate (coopdyn sim)")
ax[0].plot(tt, kin, "k:", lw=1.5, label="kinematic v_x tan(d_fl) / (L + t/2 tan(d_fl))")
ax[0].axhline(V / R, color="tab:gray", ls="--", lw=1, label="steady V / R = %.3f rad/s" % (V / R))
ax2 = ax[0].twinx()
ax2.plot(tt, [x * 180 / math.pi for x in d], color="tab:green", lw=1, label="fl_steer")
ax2.plot(tt, [x * 180 / math.pi for x in col(st, "q:fr_steer")], color="tab:olive", lw=1, label="fr_steer")
ax2.set_ylabel("steer angle, deg")
ax[0].set_xlabel("time, s (steer ramped 0.2-0.4 s to Ackermann for R = %g m, at %g m/s)" % (R, V))
ax[0].set_ylabel("yaw rate, rad/s")
ax[0].set_title("step steer: yaw rate")
ax[0].grid(alpha=0.3)
h1, l1 = ax[0].get_legend_handles_labels()
h2, l2 = ax2.get_legend_handles_labels()
ax[0].legend(h1 + h2, l1 + l2, fontsize=8, loc="lower right")
colors = {"fl": "tab:blue", "fr": "tab:orange", "rl": "tab:green", "rr": "tab:red"}
for w in ("fl", "fr", "rl", "rr"):
    u = [float(x[w + ".utilisation"]) if float(x[w + ".utilisation"]) >= 0 else float("nan") for x in st]
    ax[1].plot(tt, u, color=colors[w], lw=2, label=w + (" (inner)" if w[1] == "l" else ""))
ax[1].axhline(1.0, color="k", ls=":", lw=1)
for w in ("fl", "rl"):
    i = first(st, lambda x: float(x[w + ".utilisation"]) >= 1.0)
    if i is not None:
        ax[1].axvline(tt[i], color=colors[w], ls="--", lw=1)
        ax[1].annotate("%s reaches 1 at t = %.3f s" % (w, tt[i]), (tt[i], 1.0), fontsize=8, xytext=(4, 8 if w == "fl" else -14),
                       textcoords="offset points")
        print("step steer: %s utilisation reaches 1 at t = %.3f s (steer %.4f of %.4f rad, yaw rate %.4f rad/s)"
              % (w, tt[i], d[i], dl, yaw[i]))
ax[1].set_xlabel("time, s")
ax[1].set_ylabel("friction utilisation |f_t| / (mu N)")
ax[1].set_title("step steer: each wheel's friction utilisation (mu = %.2f)" % mu)
ax[1].grid(alpha=0.3)
ax[1].legend(fontsize=8, loc="upper left")
fig.tight_layout()
fig.savefig(os.path.join(outdir, "vehicle_step_steer.png"), dpi=110)
res = max(float(x["residual"]) for x in st)
print("step steer: final yaw rate %.6f rad/s, kinematic %.6f, V / R %.6f; speed %.4f m/s; max residual %.3g m/s^2"
      % (yaw[-1], kin[-1], V / R, vx[-1], res))
