"""Running a study: chunks of samples on Dask (or in this process), written in order to a CSV file.

The file: '#' lines (the commit, the spec's digest, the spec itself), the column names, then one row
per sample in sample order. A chunk is written whole, in one write, only after every chunk before it:
a file cut short (SIGINT, a crash) ends on a chunk boundary, and resume=True continues after it.
Chunks lost with a worker are recomputed by Dask; each chunk is written once, so each sample appears once.
"""
import os
import sys
import time

from . import compute, samples
from . import spec as specmod

_specs = {}


def _task(text, base, where, k, as_text=True):
    """Worker side: chunk k's rows, as CSV text (formatted where they are computed) or as tuples (the
    spec parsed once per process)."""
    key = (text, base)
    if key not in _specs:
        _specs[key] = specmod.load(text, base=base, where=where)
    rows = compute.run_chunk(_specs[key], k)
    return k, (format_rows(rows) if as_text else rows)


def commit():
    try:
        from ._commit import COMMIT
        return COMMIT
    except ImportError:
        return "unknown"


def _fmt(x):
    if x != x:  # NaN: no value (status says why)
        return ""
    return str(x)  # a float's shortest repr: it reads back to the same double


def format_rows(rows):
    """CSV text of rows (floats, ints, strs): the fast join, the slow path only for rows with a NaN."""
    out = []
    for r in rows:
        line = ",".join(map(str, r))
        out.append(",".join(map(_fmt, r)) if "nan" in line else line)
    return "\n".join(out) + "\n" if out else ""


def header(spec):
    lines = ["# coopdyn study: one row per sample (docs/guide/studies.md); units SI (m, kg, N, N*m)",
             f"# commit: {commit()}", f"# spec: {os.path.basename(spec.path)} sha256/16 {spec.digest}",
             f"# samples: {spec.count} chunk: {spec.chunk} seed: {spec.seed}"]
    lines += ["# | " + ln for ln in spec.text.rstrip("\n").split("\n")]
    return "\n".join(lines) + "\n" + ",".join(compute.columns(spec)) + "\n"


def _resume_point(path, head, spec):
    """Chunks already in `path` (written under the same header); the file is cut after the last whole one."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(head.encode()):
        raise specmod.StudyError(f"{path}:1: --resume: the file was not written by this spec and code "
                                 f"(its header differs); remove it or write elsewhere")
    body = data[len(head):]
    rows = body.count(b"\n")
    done = min(rows // spec.chunk, samples.chunk_count(spec)) if rows < spec.count else samples.chunk_count(spec)
    keep = len(head) + sum(len(ln) + 1 for ln in body.split(b"\n")[:min(rows, done * spec.chunk)])
    with open(path, "r+b") as f:
        f.truncate(keep)
    return done


class _Progress:
    def __init__(self, total, on):
        self.total, self.on, self.t0, self.n = total, on, time.monotonic(), 0

    def __call__(self, done, rows):
        self.n += rows
        if not self.on:
            return
        w = 30
        fill = w * done // max(self.total, 1)
        rate = self.n / max(time.monotonic() - self.t0, 1e-9)
        sys.stderr.write(f"\r[{'#' * fill}{'.' * (w - fill)}] {done}/{self.total} chunks  {rate:.0f} samples/s")
        if done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def run(source, out=None, workers=None, scheduler=None, client=None, resume=False, progress=False,
        on_chunk=None):
    """Runs the study `source` (a path or YAML text); returns the output path (or the rows if out is None
    and workers == 0). workers: 0 = in this process, N = a LocalCluster of N worker processes (default:
    one per core); scheduler: the address of a running Dask scheduler; client: a distributed.Client.
    on_chunk(k): called after chunk k is written (tests)."""
    spec = specmod.load(source)  # refuses a bad spec before any work starts
    nchunks = samples.chunk_count(spec)
    head = header(spec)
    start = 0
    if out is not None:
        if resume and os.path.exists(out):
            start = _resume_point(out, head, spec)
        else:
            with open(out, "w") as f:
                f.write(head)
    sink = open(out, "a") if out is not None else None
    rows_all = []
    bar = _Progress(nchunks, progress)
    bar(start, 0)

    def write(k, chunk):
        if sink is not None:
            sink.write(chunk)
            sink.flush()
        else:
            rows_all.extend(chunk)
        bar(k + 1, min(spec.chunk, spec.count - k * spec.chunk))
        if on_chunk is not None:
            on_chunk(k)

    args = (spec.text, spec.base, spec.path)
    as_text = sink is not None
    try:
        if workers == 0 and client is None and scheduler is None:
            for k in range(start, nchunks):
                write(k, _task(*args, k, as_text)[1])
        else:
            _run_dask(args + (as_text,), range(start, nchunks), write, workers, scheduler, client)
    finally:
        if sink is not None:
            sink.close()
    return out if out is not None else rows_all


def _run_dask(args, chunks, write, workers, scheduler, client):
    from distributed import Client, LocalCluster, as_completed
    own = []
    if client is None:
        if scheduler is not None:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            own.append(cluster)
            client = Client(cluster)
        own.insert(0, client)
    try:
        todo = iter(chunks)
        window = 4 * max(len(client.scheduler_info()["workers"]), 1)
        pending = {}
        futures = as_completed()
        for k in todo:
            futures.add(client.submit(_task, *args[:3], k, args[3], pure=False))
            if futures.count() >= window:
                break
        nxt = min(chunks) if len(chunks) else 0
        for fut in futures:
            k, rows = fut.result()
            pending[k] = rows
            fut.release()
            while nxt in pending:
                write(nxt, pending.pop(nxt))
                nxt += 1
            while futures.count() + len(pending) < window:  # at most `window` chunks held or in flight
                k2 = next(todo, None)
                if k2 is None:
                    break
                futures.add(client.submit(_task, *args[:3], k2, args[3], pure=False))
    finally:
        for o in own:
            o.close()
