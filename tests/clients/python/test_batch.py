# Scene.evaluate_batch: row r is Scene.evaluate of row r, bit for bit; inputs left out are the
# scene's initial state; two Python threads run batches at once (the GIL is released).
import threading

import numpy as np
import pytest

from conftest import SCENES

import coopdyn


def states(s, n, seed):
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(s.tau_limit), s.tau_limit, 1.0)
    Q = np.tile(s.q0, (n, 1))
    V = s.v0 + 0.05 * rng.standard_normal((n, s.nv))
    TAU = 0.2 * lim * rng.standard_normal((n, s.nv))
    return Q, V, TAU


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_batch_equals_loop(path):
    s = coopdyn.load_scene(path)
    Q, V, TAU = states(s, 6, 3)
    b = s.evaluate_batch(Q, V, TAU)
    assert b["vdot"].shape == (6, s.nv) and b["status"].shape == (6,)
    assert list(b["wrenches"]) == s.wrench_names
    for r in range(6):
        ev = s.evaluate(Q[r], V[r], TAU[r])
        assert np.array_equal(b["vdot"][r], ev.vdot)
        assert b["status"][r] == ev.status and b["reason"][r] == ev.reason
        for k in s.wrench_names:
            assert np.array_equal(b["wrenches"][k][r], ev.wrenches[k])
        assert list(b["sigma"]) == list(ev.sigma)
        for k in ev.sigma:
            assert np.array_equal(b["sigma"][k][r], ev.sigma[k])
        assert np.array_equal(b["stresses"][r], list(ev.stresses.values()))
        d = ev.diagnostics
        assert b["rank"][r] == d["rank"] and b["condition"][r] == d["condition"] and b["residual"][r] == d["residual"]


def test_left_out_inputs_are_the_initial_state():
    s = coopdyn.load_scene(next(p for p in SCENES if p.stem == "pr2_box"))
    _, _, TAU = states(s, 3, 5)
    b = s.evaluate_batch(TAU=TAU)
    for r in range(3):
        assert np.array_equal(b["vdot"][r], s.evaluate(tau=TAU[r]).vdot)
    z = s.evaluate_batch(Q=np.tile(s.q0, (2, 1)))
    assert np.array_equal(z["vdot"][1], s.evaluate().vdot)


def test_empty_batch():
    s = coopdyn.load_scene(next(p for p in SCENES if p.stem == "two_puma_load"))
    b = s.evaluate_batch(np.zeros((0, s.nq)))
    assert b["vdot"].shape == (0, s.nv) and all(w.shape == (0, 6) for w in b["wrenches"].values())


def test_two_threads_run_batches_at_once():
    """Thread A runs a long batch; the main thread, which needs the GIL to look, sees A's progress
    counter strictly between 0 and N while A is still inside evaluate_batch: impossible if A held the
    GIL for its whole call. Then the main thread runs its own batch while A goes on. A and the main
    thread's results equal those of one thread."""
    s = coopdyn.load_scene(next(p for p in SCENES if p.stem == "two_puma_load"))
    n = 20000
    for attempt in range(5):  # a loaded machine may not schedule the main thread before A ends
        Q, V, TAU = states(s, n, 11)
        progress = np.zeros(1, dtype=np.int64)
        out = {}
        a = threading.Thread(target=lambda: out.setdefault("a", s.evaluate_batch(Q, V, TAU, progress=progress)))
        a.start()
        seen = []
        while a.is_alive() and not (0 < progress[0] < n):
            seen.append(int(progress[0]))
            threading.Event().wait(0.0005)
        mid = int(progress[0])
        mine = s.evaluate_batch(Q[:50], V[:50], TAU[:50])
        a.join()
        if 0 < mid < n:
            break
        n *= 2
    assert 0 < mid < n, "never saw the other thread's batch in progress: the GIL was held"
    assert progress[0] == n
    assert np.array_equal(out["a"]["vdot"][:50], mine["vdot"])
    assert np.array_equal(out["a"]["vdot"][-1], s.evaluate(Q[-1], V[-1], TAU[-1]).vdot)
