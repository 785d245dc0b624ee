"""python3 -m coopdyn.study.plot RESULT.csv --x load.x --y load.z [--value payload] --out MAP.png

A heat map of one column of a study's result over two grid variables, the binding joint written in
each cell (payload studies), for the docs and for looking at a result.
"""
import argparse
import csv
import sys

import numpy as np


def read(path):
    with open(path) as f:
        lines = [ln for ln in f if not ln.startswith("#")]
    r = list(csv.reader(lines))
    return r[0], r[1:]


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m coopdyn.study.plot", description=__doc__.split("\n\n")[1])
    p.add_argument("result")
    p.add_argument("--x", required=True)
    p.add_argument("--y", required=True)
    p.add_argument("--value", default="payload")
    p.add_argument("--out", required=True)
    p.add_argument("--title", default=None)
    a = p.parse_args(argv)
    cols, rows = read(a.result)
    for c in (a.x, a.y, a.value):
        if c not in cols:
            print(f"{a.result}: no column {c!r} (columns: {', '.join(cols)})", file=sys.stderr)
            return 2
    ix, iy, iv = cols.index(a.x), cols.index(a.y), cols.index(a.value)
    ib = cols.index("binding") if "binding" in cols else None
    xs = sorted({float(r[ix]) for r in rows})
    ys = sorted({float(r[iy]) for r in rows})
    Z = np.full((len(ys), len(xs)), np.nan)
    B = [[""] * len(xs) for _ in ys]
    for r in rows:
        i, j = ys.index(float(r[iy])), xs.index(float(r[ix]))
        Z[i, j] = float(r[iv]) if r[iv] else np.nan
        if ib is not None:
            B[i][j] = r[ib]
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 6))
    dx = (xs[1] - xs[0]) / 2 if len(xs) > 1 else 0.5
    dy = (ys[1] - ys[0]) / 2 if len(ys) > 1 else 0.5
    im = ax.imshow(Z, origin="lower", extent=(xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy), aspect="auto",
                   cmap="viridis")
    fig.colorbar(im, ax=ax, label=a.value + (" (kg)" if a.value == "payload" else ""))
    if ib is not None:
        short = {b: b.replace("arm", "a").replace(".q", "q") for row in B for b in row}
        for i, y in enumerate(ys):
            for j, x in enumerate(xs):
                if not np.isnan(Z[i, j]):
                    ax.text(x, y, short[B[i][j]], ha="center", va="center", fontsize=6, color="w")
    ax.set_xlabel(a.x + " (m)")
    ax.set_ylabel(a.y + " (m)")
    ax.set_title(a.title or f"{a.value}: {a.result.split('/')[-1]}")
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
