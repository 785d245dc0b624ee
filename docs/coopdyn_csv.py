"""Reads a coopdyn per-step CSV (docs/conventions.md, "Per-step CSV"): `coopdyn sim --out`, or the
output_t channel of `coopdyn log` (DIR/COOPDYN_OUTPUT.csv), or any other CSV of `coopdyn log`.

    import coopdyn_csv
    run = coopdyn_csv.read("sim.csv")
    run.col("t"), run.col("left.fz")      # numpy arrays
    run.units["left.fz"]                   # "N"
    run.text("status")                     # the words of a text column
    run.wrenches["left"]                   # {"kind": "tip", "frame": "left.contact", "by": "ground"}

The same lines with pandas: pandas.read_csv(path, comment="#").
"""
import csv

import numpy as np


class Run:
    def __init__(self, path):
        self.path, self.comments, self.units, self.wrenches = path, [], {}, {}
        with open(path, newline="") as f:
            line = f.readline()
            while line.startswith("#"):
                self.comments.append(line[1:].strip())
                line = f.readline()
            self.names = line.rstrip("\r\n").split(",")
            self.rows = [r for r in csv.reader(f) if len(r) == len(self.names)]
        self.index = {n: i for i, n in enumerate(self.names)}
        for c in self.comments:
            if c.startswith("units: "):
                self.units = dict(zip(self.names, c[len("units: "):].split(",")))
            elif c.startswith("wrench "):
                name, rest = c[len("wrench "):].split(": ", 1)
                self.wrenches[name] = dict(p.split(" ", 1) for p in rest.split(", "))
        self.scene = ""
        if self.comments and "scene " in self.comments[0]:
            self.scene = self.comments[0].split("scene ", 1)[1].split(",")[0]

    def __contains__(self, name):
        return name in self.index

    def col(self, name):
        """A numeric column as a numpy array (KeyError naming the file when absent)."""
        if name not in self.index:
            raise KeyError(f"{self.path}: no column '{name}' (it has {', '.join(self.names[:8])}, ...)")
        i = self.index[name]
        return np.array([float(r[i]) for r in self.rows])

    def text(self, name):
        i = self.index[name]
        return [r[i] for r in self.rows]

    def row(self, k):
        """Row k as a dict of column name -> text."""
        return dict(zip(self.names, self.rows[k]))

    def dicts(self):
        return [dict(zip(self.names, r)) for r in self.rows]


def read(path):
    return Run(path)
