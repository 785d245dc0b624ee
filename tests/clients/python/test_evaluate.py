# Scene.evaluate against `coopdyn eval`: on every shipped scene the same doubles (vdot, every wrench,
# its frame, sigma, stresses, diagnostics), at the scene's initial state and at a state with velocity
# and torque; dict and array inputs agree; --hold and hold=True agree.
import math

import numpy as np
import pytest

from conftest import SCENES, cli_eval

import coopdyn


def same(a, b):
    """Bit for bit, with JSON's null for a non-finite number."""
    a = np.asarray(a, dtype=float).ravel()
    b = [math.nan if x is None else x for x in np.asarray(b, dtype=object).ravel()]
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert (math.isnan(x) and math.isnan(y)) or (x == y and math.copysign(1, x) == math.copysign(1, y)), (a, b)


def check(ev, js):
    same(ev.vdot, js["vdot"])
    assert ev.status == js["diagnostics"]["status"]
    assert ev.diagnostics["reason_text"] == js["diagnostics"]["reason"]
    assert list(ev.wrenches) == [w["name"] for w in js["wrenches"]]
    for w in js["wrenches"]:
        same(ev.wrenches[w["name"]], w["moment"] + w["force"])
        X = ev.wrench_frames[w["name"]]
        same(X[:3, 3], w["frame_W"]["p"])
        same(X[:3, :3], w["frame_W"]["R"])
        assert np.array_equal(X[3], [0, 0, 0, 1])
        if "sigma" in w:
            same(ev.sigma[w["name"]], w["sigma"])
    assert bool(ev.sigma) == any("sigma" in w for w in js["wrenches"])
    assert list(ev.stresses) == [s["joint"] for s in js["stresses"]]
    same(list(ev.stresses.values()), [s["value"] for s in js["stresses"]])
    d = ev.diagnostics
    for k in ("rows", "rank", "indeterminate"):
        assert d[k] == js["diagnostics"][k]
    same([d["condition"], d["residual"]], [js["diagnostics"]["condition"], js["diagnostics"]["residual"]])


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_initial_state_equals_cli(path):
    s = coopdyn.load_scene(str(path))
    js = cli_eval(path)
    assert js["coordinates"]["q"] == s.q_names and js["coordinates"]["v"] == s.v_names
    same(s.q0, js["q"])
    same(s.v0, js["v"])
    check(s.evaluate(), js)
    check(s.evaluate(s.q0, s.v0, np.zeros(s.nv)), js)


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_moving_state_equals_cli(path, tmp_path):
    s = coopdyn.load_scene(path)  # a PathLike too
    rng = np.random.default_rng(7)
    lim = np.where(np.isfinite(s.tau_limit), s.tau_limit, 1.0)
    state = {"q": s.q0, "v": s.v0 + 0.05 * rng.standard_normal(s.nv), "tau": 0.2 * lim * rng.standard_normal(s.nv)}
    js = cli_eval(path, state, tmp_path)
    ev = s.evaluate(state["q"], state["v"], state["tau"])
    check(ev, js)
    # the same state by name, and as lists
    ev_d = s.evaluate(dict(zip(s.q_names, state["q"])), dict(zip(s.v_names, state["v"])),
                      dict(zip(s.v_names, state["tau"])))
    check(ev_d, js)
    check(s.evaluate(list(state["q"]), list(state["v"]), list(state["tau"])), js)


@pytest.mark.parametrize("name", ["pr2_box", "two_puma_load"])
def test_hold_equals_cli(name, tmp_path):
    path = next(p for p in SCENES if p.stem == name)
    s = coopdyn.load_scene(path)
    js = cli_eval(path, hold=True)
    ev = s.evaluate(hold=True)
    check(ev, js)
    same(s.holding_torque(), js["tau"])
    # holding torques hold: the accelerations vanish where the actuators can hold the state
    assert np.max(np.abs(ev.vdot)) < 1e-6


def test_partial_dict_keeps_initial_state():
    s = coopdyn.load_scene(str(next(p for p in SCENES if p.stem == "two_puma_load")))
    name = s.v_names[1]
    tau = np.zeros(s.nv)
    tau[1] = 3.0
    a = s.evaluate(tau={name: 3.0})
    b = s.evaluate(s.q0, s.v0, tau)
    assert np.array_equal(a.vdot, b.vdot)
    for k in a.wrenches:
        assert np.array_equal(a.wrenches[k], b.wrenches[k])


def test_result_is_a_copy():
    s = coopdyn.load_scene(str(next(p for p in SCENES if p.stem == "two_puma_load")))
    a = s.evaluate()
    keep = a.vdot.copy(), {k: w.copy() for k, w in a.wrenches.items()}
    s.evaluate(tau=np.ones(s.nv))
    assert np.array_equal(a.vdot, keep[0])
    assert all(np.array_equal(a.wrenches[k], keep[1][k]) for k in keep[1])
