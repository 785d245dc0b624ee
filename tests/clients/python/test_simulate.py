# Scene.simulate against `coopdyn sim`: every column of the CSV (t, q, v, tau, vdot, wrenches, sigma,
# stresses, status) equal to the returned arrays, bit for bit; a callable torque equals the
# command line's profile that computes the same torque.
import csv
import io

import numpy as np
import pytest

from conftest import SCENES, run_cli

import coopdyn


def sim_csv(*args):
    rc, out, err = run_cli("sim", *args)
    assert rc in (0, 3), err
    rows = [r for r in csv.reader(io.StringIO(out)) if r and not r[0].startswith("#")]
    head = rows[0]
    return {h: [r[i] for r in rows[1:]] for i, h in enumerate(head)}


def same_column(cells, values):
    assert len(cells) == len(values)
    for c, x in zip(cells, values):
        assert float(c) == x or (np.isnan(x) and c.lower() == "nan"), (c, x)


def compare(s, run, col):
    same_column(col["t"], run["t"])
    for i, n in enumerate(s.q_names):
        same_column(col["q:" + n], run["q"][:, i])
    for key in ("v", "tau", "vdot"):
        for i, n in enumerate(s.v_names):
            same_column(col[key + ":" + n], run[key][:, i])
    for n in s.wrench_names:
        for c, comp in enumerate(("mx", "my", "mz", "fx", "fy", "fz")):
            same_column(col[n + "." + comp], run["wrenches"][n][:, c])
            if run["sigma"]:
                same_column(col[n + ".sigma_" + comp], run["sigma"][n][:, c])
    assert bool(run["sigma"]) == any(h.endswith(".sigma_mx") for h in col)
    for i, n in enumerate(s.stress_names):
        same_column(col["stress:" + n], run["stresses"][:, i])
    assert list(col["status"]) == list(run["status"])
    assert list(col["reason"]) == list(run["reason"])


CASES = {
    "two_puma_load": ["--torque", "arm1.q2:constant:4.5", "--torque", "arm2.q3:step:-2:0.01"],
    "pr2_box": ["--hold"],
    "four_wheel_car": [],
    "tiago_pro_box": ["--hold", "--integrator", "semi_implicit_euler", "--every", "3"],
}


@pytest.mark.parametrize("name", list(CASES))
def test_simulate_equals_cli(name):
    path = next(p for p in SCENES if p.stem == name)
    s = coopdyn.load_scene(path)
    args = CASES[name]
    opts = dict(hold="--hold" in args)
    if "--integrator" in args:
        opts["integrator"] = args[args.index("--integrator") + 1]
    if "--every" in args:
        opts["every"] = int(args[args.index("--every") + 1])
    if name == "two_puma_load":
        opts["torque"] = lambda t, q, v: {"arm1.q2": 4.5, "arm2.q3": -2.0 if t >= 0.01 else 0.0}
    col = sim_csv("--scene", path, "--duration", 0.03, "--dt", 0.002, *args)
    run = s.simulate(0.03, 0.002, **opts)
    assert run["stopped"] is None
    compare(s, run, col)


def test_constant_array_torque_equals_profile():
    path = next(p for p in SCENES if p.stem == "two_puma_load")
    s = coopdyn.load_scene(path)
    tau = np.zeros(s.nv)
    tau[s.v_names.index("arm1.q2")] = 4.5
    tau[s.v_names.index("arm2.q5")] = -0.25
    col = sim_csv("--scene", path, "--duration", 0.02, "--dt", 0.001, "--torque", "arm1.q2:constant:4.5",
                  "--torque", "arm2.q5:constant:-0.25")
    a = s.simulate(0.02, 0.001, torque=tau)
    compare(s, a, col)
    b = s.simulate(0.02, 0.001, torque={"arm1.q2": 4.5, "arm2.q5": -0.25})
    for k in ("q", "v", "vdot"):
        assert np.array_equal(a[k], b[k])


def test_sim_start_row_is_evaluate():
    s = coopdyn.load_scene(next(p for p in SCENES if p.stem == "pr2_box"))
    run = s.simulate(0.0, 0.001)
    ev = s.evaluate()
    assert run["t"].shape == (1,)
    assert np.array_equal(run["vdot"][0], ev.vdot)
    for n in s.wrench_names:
        assert np.array_equal(run["wrenches"][n][0], ev.wrenches[n])
