#!/usr/bin/env python3
"""The Python bindings' call overhead, measured side by side in one run (bench/README.md, "Python").

  PYTHONPATH=build/python python3 bench/python_bindings.py [--scene config/scenes/two_puma_load.yaml]
      [--states 1000] [--batch 100000] [--rounds 7]

Per state, on the same states (the scene's q0, random v and tau):
  C++        the evaluation Scene.evaluate makes (evaluate, the wrenches, their sigma) in a C++ loop
  evaluate   Scene.evaluate(q, v, tau) from a Python loop, numpy arrays in, an Evaluation out
  batch      Scene.evaluate_batch(Q, V, TAU) of --batch states (GIL released, arrays out)
Rounds alternate them; each figure is the fastest round (on a loaded machine the least disturbed: other
processes only ever add time), the median beside it, with the goals (evaluate <= 1.3 x C++ + 1 us,
batch >= 90 % of the C++ rate).
"""
import argparse
import os
import statistics
import sys
import time

import numpy as np

import coopdyn


def states(s, n, seed=1):
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(s.tau_limit), s.tau_limit, 1.0)
    return (np.tile(s.q0, (n, 1)), s.v0 + 0.05 * rng.standard_normal((n, s.nv)),
            0.2 * lim * rng.standard_normal((n, s.nv)))


def python_loop(s, rows):
    ev = s.evaluate
    t0 = time.perf_counter()
    for q, v, tau in rows:
        ev(q, v, tau)
    return (time.perf_counter() - t0) / len(rows)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(here, "..", "config", "scenes", "two_puma_load.yaml"))
    ap.add_argument("--states", type=int, default=1000)
    ap.add_argument("--batch", type=int, default=100000)
    ap.add_argument("--rounds", type=int, default=7)
    a = ap.parse_args()
    s = coopdyn.load_scene(a.scene)
    Q, V, TAU = states(s, a.states)
    rows = list(zip(list(Q), list(V), list(TAU)))
    QB, VB, TB = states(s, a.batch, 2)
    cxx, py, cxx_b, batch = [], [], [], []
    python_loop(s, rows[:100])  # warm the caches
    for _ in range(a.rounds):
        cxx.append(s._time_evaluate(Q, V, TAU, 3))
        py.append(python_loop(s, rows))
        cxx_b.append(s._time_evaluate(QB, VB, TB, 1))
        t0 = time.perf_counter()
        s.evaluate_batch(QB, VB, TB)
        batch.append((time.perf_counter() - t0) / a.batch)
    us = 1e6
    print("scene %s (nq %d, nv %d, %d wrenches), %d rounds: fastest (median); load average %.1f" %
          (s.name, s.nq, s.nv, len(s.wrench_names), a.rounds, os.getloadavg()[0]))
    for pick in (min, statistics.median):
        c, p, cb, b = (pick(x) for x in (cxx, py, cxx_b, batch))
        print("%s round" % ("fastest" if pick is min else "median"))
        print("  C++ evaluation (evaluate, wrenches, sigma) %8.3f us/state" % (c * us))
        print("  Scene.evaluate from Python              %8.3f us/call  = %.3f x C++ + %.3f us "
              "(goal <= 1.3 x + 1 us: %s)"
              % (p * us, p / c, (p - c) * us, "met" if p <= 1.3 * c + 1e-6 else "NOT met"))
        print("  C++ loop, %d states                  %8.3f us/state" % (a.batch, cb * us))
        print("  Scene.evaluate_batch, %d states      %8.3f us/state = %.1f %% of the C++ rate (goal >= 90 %%: %s)"
              % (a.batch, b * us, 100 * cb / b, "met" if cb / b >= 0.9 else "NOT met"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
