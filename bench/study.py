#!/usr/bin/env python3
"""coopdyn.study's throughput and overhead, side by side in one run (bench/README.md, "Studies").

  PYTHONPATH=build/python python3 bench/study.py [--samples 20000] [--payload-spec config/studies/payload_two_puma.yaml]

  bare       Scene.evaluate_batch over the study's own states and torques, chunk by chunk (the floor)
  serial     the same study through coopdyn.study in this process (workers=0), CSV written
  dask N     the same on a LocalCluster of N worker processes (started before the clock; its start
             is reported apart), N = 1, 2
and the payload map (IK, two holding torques and two evaluations per pose) serially and on 1 and 2
workers. Samples per second; the ratios are taken within this run (the machine is shared).
"""
import argparse
import os
import sys
import tempfile
import time

import numpy as np

from coopdyn import study
from coopdyn.study import samples

EVAL = """scene: {scene}
kind: evaluate
seed: 3
draws: {n}
chunk: {chunk}
variables:
  tau.arm1.q2: {{normal: [0, 20]}}
  tau.arm2.q2: {{normal: [0, 20]}}
  tau.arm1.q3: {{normal: [0, 10]}}
"""


def bare(spec):
    s = spec.scene
    t0 = time.perf_counter()
    for k in range(samples.chunk_count(spec)):
        idx, values = samples.chunk_values(spec, k)
        n = len(idx)
        TAU = np.zeros((n, s.nv))
        for name, col in values.items():
            TAU[:, s.v_names.index(name[4:])] = col
        s.evaluate_batch(np.tile(s.q0, (n, 1)), np.tile(s.v0, (n, 1)), TAU)
    return time.perf_counter() - t0


def timed(source, out, **kw):
    t0 = time.perf_counter()
    study(source, out=out, **kw)
    return time.perf_counter() - t0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--samples", type=int, default=20000)
    p.add_argument("--chunk", type=int, default=1000)
    p.add_argument("--scene", default="config/scenes/two_puma_load.yaml")
    p.add_argument("--payload-spec", default="config/studies/payload_two_puma.yaml")
    a = p.parse_args()
    from distributed import Client, LocalCluster
    text = EVAL.format(scene=os.path.abspath(a.scene), n=a.samples, chunk=a.chunk)
    spec = study.load(text)
    tmp = tempfile.mkdtemp()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    tb = bare(spec)
    ts = timed(text, os.path.join(tmp, "s.csv"), workers=0)
    n = spec.count
    print(f"evaluate kind, {n} samples, chunk {a.chunk}:")
    print(f"  bare evaluate_batch loop  {n / tb:10.0f} samples/s")
    print(f"  serial (workers=0, CSV)   {n / ts:10.0f} samples/s   overhead {100 * (ts / tb - 1):.0f} %")
    pay = study.load(a.payload_spec)
    tp0 = timed(a.payload_spec, os.path.join(tmp, "p0.csv"), workers=0)
    print(f"payload map, {pay.count} poses: serial {pay.count / tp0:.1f} poses/s")
    rates = {}
    for w in (1, 2):
        t0 = time.perf_counter()
        with LocalCluster(n_workers=w, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
                Client(c) as client:
            client.wait_for_workers(w)
            up = time.perf_counter() - t0
            timed(text, os.path.join(tmp, "warm.csv"), client=client)  # the workers import and load once
            te = timed(text, os.path.join(tmp, f"e{w}.csv"), client=client)
            tp = timed(a.payload_spec, os.path.join(tmp, f"p{w}.csv"), client=client)
        rates[w] = (n / te, pay.count / tp)
        print(f"dask {w} worker(s) (cluster up in {up:.1f} s): evaluate {n / te:.0f} samples/s "
              f"(overhead vs bare {100 * (te / tb - 1):.0f} %), payload {pay.count / tp:.1f} poses/s")
        same = open(os.path.join(tmp, f"e{w}.csv"), "rb").read() == open(os.path.join(tmp, "s.csv"), "rb").read()
        print(f"  file identical to serial: {same}")
    print(f"2 workers / 1 worker: evaluate {rates[2][0] / rates[1][0]:.2f} x, "
          f"payload {rates[2][1] / rates[1][1]:.2f} x")
    print(f"load average {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
