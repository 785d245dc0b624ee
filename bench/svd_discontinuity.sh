#!/bin/bash
# Regenerates bench/results/svd_discontinuity.csv and docs/svd_discontinuity.png (the SVD baseline
# against the mobile platform along a path through arm1's wrist singularity, see
# bench/svd_discontinuity.cc). Needs a build with -DCOOPDYN_BUILD_BENCH=ON and /usr/bin/python3 with
# matplotlib. Prints the largest neighbour jump of each method for 51..3201 samples.
set -euo pipefail
cd "$(dirname "$0")/.."
build/bin/svd_discontinuity bench/results/svd_discontinuity.csv
/usr/bin/python3 - <<'PY'
import csv
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open("bench/results/svd_discontinuity.csv")))
col = lambda k: [float(r[k]) for r in rows]
q5 = col("arm1_q5")
fig, ax = plt.subplots(3, 1, figsize=(8, 10), sharex=True)
for k in range(1, 7):
    ax[0].plot(q5, col(f"arm1.base.sv_G{k}"), "b-", lw=1, label="G_k of arm1.base (platform columns incl.)" if k == 1 else None)
    ax[0].plot(q5, col(f"arm1.base.sv_arm{k}"), "r--", lw=1, label="arm1's own 6x6 Jacobian" if k == 1 else None)
ax[0].set_ylabel("singular values")
ax[0].set_yscale("log")
ax[0].set_ylim(1e-3, None)
ax[0].legend(fontsize=8)
ax[0].set_title("two_puma_load: arm1.q5 through the wrist singularity (q5 = 0), chain kept closed", fontsize=10)
for c, name in zip("bgrcmy", ["mx", "my", "mz", "fx", "fy", "fz"]):
    ax[1].plot(q5, col(f"arm1.base.mp.{name}"), c + "-", lw=1.5, label=name + " mobile platform")
    ax[1].plot(q5, col(f"arm1.base.svd.{name}"), "k:", lw=1, label="svd baseline" if name == "mx" else None)
ax[1].set_ylabel("arm1 base wrench (N*m, N)")
ax[1].legend(fontsize=7, ncol=4)
ax[2].semilogy(q5, [max(x, 1e-17) for x in col("dlambda")], "k-", lw=1)
ax[2].set_ylabel("max |lambda_svd - lambda_mp|")
ax[2].set_xlabel("arm1.q5 (rad)")
for a in ax:
    a.axvline(0.0, color="gray", lw=0.5)
ax[2].invert_xaxis()
fig.tight_layout()
fig.savefig("docs/svd_discontinuity.png", dpi=110)
print("wrote docs/svd_discontinuity.png")
PY
