"""The variables' values of a chunk of samples: the same numbers whoever computes the chunk.

Sample i is grid point i // draws (grids in file order, the last one fastest) and draw i % draws.
Random draws come from numpy's PCG64 seeded by (seed, chunk index), one column per random variable
in file order: a chunk's values depend only on the spec and the chunk, never on the worker or on
which chunks ran before.
"""
import numpy as np


def chunk_bounds(spec, k):
    lo = k * spec.chunk
    return lo, min(lo + spec.chunk, spec.count)


def chunk_count(spec):
    return -(-spec.count // spec.chunk)


def chunk_values(spec, k):
    """(index (n,), {variable name: values (n,)}) of chunk k."""
    lo, hi = chunk_bounds(spec, k)
    idx = np.arange(lo, hi, dtype=np.int64)
    out = {}
    grids = spec.grids
    if grids:
        point = np.unravel_index(idx // spec.draws, spec.grid_shape)
        for v, p in zip(grids, point):
            out[v.name] = np.asarray(v.grid_values(), dtype=float)[p]
    rng = np.random.Generator(np.random.PCG64([spec.seed, k]))
    for v in spec.draws_vars:
        a, b = v.args
        out[v.name] = rng.uniform(a, b, hi - lo) if v.sampler == "uniform" else rng.normal(a, b, hi - lo)
    return idx, out
