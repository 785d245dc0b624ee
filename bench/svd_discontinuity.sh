#!/bin/bash
# Regenerates the SVD-baseline measurements (bench/svd_discontinuity.cc): bench/results/
# svd_singularity.csv and svd_deficient.csv, and the plots docs/svd_singularity.png and
# docs/svd_deficient.png; prints the tables of bench/README.md ("The SVD baseline, measured").
# Needs a build with -DCOOPDYN_BUILD_BENCH=ON and /usr/bin/python3 with matplotlib.
#   bench/svd_discontinuity.sh              measure, then plot
#   bench/svd_discontinuity.sh --plot-only  plot the CSVs in bench/results (seconds)
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${1:-}" = "--plot-only" ] || build/bin/svd_discontinuity bench/results
/usr/bin/python3 - <<'PY'
import csv
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
plt.rcParams.update({"font.size": 11, "legend.fontsize": 9})
def load(p, x):
    # rows in increasing x (the sweep runs arm1.q5 from +0.6 down to -0.6): every axis left to right
    rows = sorted(csv.DictReader(open(p)), key=lambda r: float(r[x]))
    return lambda k: [float(r[k]) for r in rows]
comps = ["mx", "my", "mz", "fx", "fy", "fz"]

c = load("bench/results/svd_singularity.csv", "arm1_q5")
q5 = c("arm1_q5")
fig, ax = plt.subplots(3, 1, figsize=(9, 10), sharex=True)
for k in range(1, 7):
    ax[0].plot(q5, [max(x, 1e-18) for x in c(f"sv{k}")], lw=1.2, label=f"sigma {k}")
ax[0].axhline(1e-5 * max(c("sv1")), color="gray", ls="--", lw=0.8, label="rank tolerance (1e-5 sigma 1)")
ax[0].set_yscale("log"); ax[0].set_ylim(1e-6, None)
ax[0].set_ylabel("singular values of\narm1's own Jacobian", fontsize=10)
ax[0].legend(fontsize=8, ncol=4, loc="lower left")
ax[0].set_title("two_puma_load: arm1.q5 through the wrist singularity (q5 = 0), chain kept closed, gravity statics", fontsize=10)
for i, k in enumerate(comps):
    ax[1].plot(q5, c(f"mp.{k}"), color=f"C{i}", lw=1.5, label=f"{k} mobile platform")
    ax[1].plot(q5, c(f"svd.{k}"), "k:", lw=1, label="svd baseline" if i == 0 else None)
ax[1].set_ylabel("arm1.ee wrench (N*m, N):\nthe load on the end-effector", fontsize=10)
ax[1].legend(fontsize=7, ncol=4)
dev = [max(abs(c(f"svd.{k}")[j] - c(f"mp.{k}")[j]) for k in comps) for j in range(len(q5))]
ax[2].semilogy(q5, [max(x, 1e-17) for x in dev], "k.-", lw=0.8, ms=3)
ax[2].set_ylabel("max |w_svd - w_mp| (N*m, N)")
ax[2].set_xlabel("arm1.q5 (rad), increasing: the baseline drops a direction only within 4.6e-5 rad of 0 (one sample here)")
ax[2].set_xlim(min(q5), max(q5))
for a in ax: a.axvline(0.0, color="gray", lw=0.5)
fig.tight_layout(); fig.savefig("docs/svd_singularity.png", dpi=100); print("wrote docs/svd_singularity.png")

c = load("bench/results/svd_deficient.csv", "arm1_q2")
q2 = c("arm1_q2")
fig, ax = plt.subplots(3, 1, figsize=(9, 8.5), sharex=True)
ax[0].plot(q2, c("lost"), "r-", lw=1.5)
ax[0].set_ylabel("rigid grasp force along N(J^T)\n(N*m, N mixed as u mixes them)", fontsize=9)
ax[0].set_title("two_5dof_arms_load (joint 6 held): what the SVD baseline drops at arm1's grasp", fontsize=10)
ax[1].plot(q2, [100 * x for x in c("share")], "r-", lw=1.5)
ax[1].set_ylabel("share of the grasp wrench (%)")
ax[2].plot(q2, c("opening"), "b-", lw=1.5)
ax[2].set_ylabel("baseline's grasp opening\nu.(G vdot - gamma) (m/s^2, rad/s^2)", fontsize=9)
ax[2].set_xlabel("arm1.q2 (rad), increasing")
ax[2].set_xlim(min(q2), max(q2))
for a in ax: a.grid(True)
fig.tight_layout(); fig.savefig("docs/svd_deficient.png", dpi=100); print("wrote docs/svd_deficient.png")
PY
