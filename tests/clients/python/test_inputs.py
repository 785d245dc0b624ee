# Bad input raises ValueError naming the argument and the index or name; a broken scene raises
# SceneError with the message `coopdyn eval` prints.
import re

import numpy as np
import pytest

from conftest import SCENES, run_cli

import coopdyn

PUMA = str(next(p for p in SCENES if p.stem == "two_puma_load"))


@pytest.fixture(scope="module")
def s():
    return coopdyn.load_scene(PUMA)


def raises(match, f, *a, **kw):
    with pytest.raises(ValueError, match=match):
        f(*a, **kw)


def test_wrong_shapes(s):
    raises(r"^q: expected shape \(%d,\) in the order of the scene's q_names, got shape \(3,\)" % s.nq,
           s.evaluate, np.zeros(3))
    raises(r"^v: expected shape \(%d,\).*v_names, got shape \(%d, 1\)" % (s.nv, s.nv), s.evaluate, None,
           np.zeros((s.nv, 1)))
    raises(r"^tau: expected shape", s.evaluate, None, None, np.zeros(s.nv + 1))
    raises(r"^tau: expected numbers", s.evaluate, None, None, "abc")
    raises(r"^Q: expected shape \(N, %d\)" % s.nq, s.evaluate_batch, np.zeros((4, s.nq + 1)))
    raises(r"^V: has 3 rows, the other inputs 4", s.evaluate_batch, np.zeros((4, s.nq)), np.zeros((3, s.nv)))
    raises(r"^evaluate_batch: give at least one of Q, V, TAU", s.evaluate_batch)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_not_finite_names_index_and_coordinate(s, bad):
    for arg, names, pos in (("q", s.q_names, 0), ("v", s.v_names, 1), ("tau", s.v_names, 2)):
        x = [None, None, None]
        base = {"q": s.q0, "v": s.v0, "tau": np.zeros(s.nv)}[arg].copy()
        base[3] = bad
        x[pos] = base
        word = "NaN" if np.isnan(bad) else "infinite"
        raises(r"^%s\[3\] \(%s\) is %s" % (arg, re.escape(names[3]), word), s.evaluate, *x)
        x[pos] = {names[3]: bad}
        raises(r"^%s\['%s'\] is %s" % (arg, re.escape(names[3]), word), s.evaluate, *x)
    Q = np.tile(s.q0, (5, 1))
    Q[4, 2] = bad
    raises(r"^Q\[4, 2\] \(%s\) is" % re.escape(s.q_names[2]), s.evaluate_batch, Q)
    raises(r"^torque\[0\]", s.simulate, 0.01, 0.001, torque=np.full(s.nv, bad))


def test_unknown_names_and_non_numbers(s):
    raises(r"^tau: unknown name 'no_such_joint'", s.evaluate, tau={"no_such_joint": 1.0})
    raises(r"^q: unknown name 'arm9\.q1'", s.evaluate, {"arm9.q1": 0.0})
    raises(r"^tau\['%s'\] is not a number" % re.escape(s.v_names[0]), s.evaluate, tau={s.v_names[0]: "x"})
    raises(r"^tau: keys must be names", s.evaluate, tau={3: 1.0})
    raises(r"^name: unknown frame 'nowhere'", s.frame_pose, "nowhere")
    raises(r"^name: unknown frame", s.jacobian, "nowhere")
    raises(r"^torque\(t=0\.000000\): unknown name 'x'", s.simulate, 0.01, 0.001, torque=lambda t, q, v: {"x": 1.0})
    raises(r"^torque\(t=0\.000000\): expected shape", s.simulate, 0.01, 0.001, torque=lambda t, q, v: np.zeros(2))


def test_bad_run_settings(s):
    raises(r"^dt: must be finite and > 0", s.simulate, 1.0, 0.0)
    raises(r"^duration: must be finite and >= 0", s.simulate, np.nan, 0.001)
    raises(r"^integrator: unknown 'euler'", s.simulate, 0.1, 0.001, integrator="euler")
    raises(r"^every: must be >= 1", s.simulate, 0.1, 0.001, every=0)
    raises(r"^formulation: unknown 'fast'", coopdyn.load_scene, PUMA, formulation="fast")
    raises(r"^progress: expected a writable numpy int64 array", s.evaluate_batch, np.tile(s.q0, (2, 1)),
           progress=[0])


def test_invalid_state_is_a_status_not_an_exception(s):
    q = s.q0.copy()
    q[:] = 0  # quaternions of zero norm where the scene has floating joints
    if s.q_names[0].endswith(".x"):
        ev = s.evaluate(q)
        assert ev.status == "error" and np.all(np.isfinite(ev.vdot) | (ev.vdot == 0))


def test_broken_scene_message_is_the_cli_message(tmp_path):
    broken = tmp_path / "broken.yaml"
    text = open(PUMA).read().replace("arms:", "arms:\n  - {robot: nothing_here, frobnicate: 1}", 1)
    broken.write_text(text)
    rc, out, err = run_cli("eval", "--scene", broken)
    assert rc == 1
    with pytest.raises(coopdyn.SceneError) as e:
        coopdyn.load_scene(str(broken))
    assert err.splitlines()[0] == "coopdyn: " + str(e.value)
    assert re.match(r"^%s:\d+:\d+: " % re.escape(str(broken)), str(e.value))
    assert isinstance(e.value, ValueError)
    # the same text given as YAML names <string> and the same line and column
    with pytest.raises(coopdyn.SceneError) as e2:
        coopdyn.load_scene(text.replace("robots/", str(tmp_path) + "/robots/"))
    assert str(e2.value).startswith("<string>:")
    # a missing file
    with pytest.raises(coopdyn.SceneError) as e3:
        coopdyn.load_scene(str(tmp_path / "none.yaml"))
    rc, out, err = run_cli("eval", "--scene", tmp_path / "none.yaml")
    assert err.splitlines()[0] == "coopdyn: " + str(e3.value)


def test_yaml_text_loads_like_the_file():
    text = open(PUMA).read()
    import os
    cwd = os.getcwd()
    os.chdir(os.path.dirname(PUMA))  # the scene's robot paths are relative to it
    try:
        a = coopdyn.load_scene(text)
    finally:
        os.chdir(cwd)
    b = coopdyn.load_scene(PUMA)
    assert a.q_names == b.q_names and np.array_equal(a.q0, b.q0)
    assert np.array_equal(a.evaluate().vdot, b.evaluate().vdot)
