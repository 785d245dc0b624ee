# frame_pose, jacobian, mass_matrix: the Jacobian's columns are the finite differences of the frame's
# pose (world axes, [angular; linear] at the frame's origin); M(q) is symmetric positive definite and
# its platform translation block is the total mass times the identity at every configuration.
import numpy as np
import pytest

from conftest import SCENES

import coopdyn


def scene(name):
    return coopdyn.load_scene(next(p for p in SCENES if p.stem == name))


@pytest.mark.parametrize("name", ["two_puma_load", "pr2_box", "planar_arms_load"])
def test_jacobian_is_the_pose_derivative(name):
    s = scene(name)
    joints = [i for i, n in enumerate(s.v_names) if n in s.q_names]  # 1-DOF joints: q and v alike
    assert joints
    h = 1e-6
    for f in s.frame_names:
        q = s.q0.copy()
        J = s.jacobian(f, q)
        assert J.shape == (6, s.nv)
        for i in joints[:: max(1, len(joints) // 6)]:
            k = s.q_names.index(s.v_names[i])
            qp, qm = q.copy(), q.copy()
            qp[k] += h
            qm[k] -= h
            Xp, Xm = s.frame_pose(f, qp), s.frame_pose(f, qm)
            dp = (Xp[:3, 3] - Xm[:3, 3]) / (2 * h)
            W = (Xp[:3, :3] @ Xm[:3, :3].T - Xm[:3, :3] @ Xp[:3, :3].T) / (4 * h)  # skew(w)
            w = np.array([W[2, 1], W[0, 2], W[1, 0]])
            assert np.allclose(J[:3, i], w, atol=1e-6), (f, s.v_names[i])
            assert np.allclose(J[3:, i], dp, atol=1e-6), (f, s.v_names[i])
        X = s.frame_pose(f, q)
        assert np.allclose(X[:3, :3] @ X[:3, :3].T, np.eye(3), atol=1e-12) and np.array_equal(X[3], [0, 0, 0, 1])


def test_pose_at_dict_configuration():
    s = scene("two_puma_load")
    f = s.frame_names[0]
    q = s.q0.copy()
    q[s.q_names.index("arm1.q2")] += 0.1
    assert np.array_equal(s.frame_pose(f, q), s.frame_pose(f, {"arm1.q2": s.q0[s.q_names.index("arm1.q2")] + 0.1}))


@pytest.mark.parametrize("name", ["two_puma_load", "pr2_box"])
def test_mass_matrix(name):
    s = scene(name)
    rng = np.random.default_rng(2)
    M0 = s.mass_matrix()
    q = s.q0.copy()
    for k, n in enumerate(s.q_names):
        if n in s.v_names:
            q[k] += 0.3 * rng.standard_normal()
    M = s.mass_matrix(q)
    assert M.shape == (s.nv, s.nv)
    assert np.array_equal(M, M.T)
    assert np.min(np.linalg.eigvalsh(M)) > 0
    t = [s.v_names.index(n) for n in s.v_names if n.endswith((".vx", ".vy", ".vz"))]
    if len(t) == 3:  # a floating root carrying everything: m I whatever the joints' angles
        m = M0[t[0], t[0]]
        assert m > 0
        assert np.allclose(M[np.ix_(t, t)], m * np.eye(3), rtol=1e-12, atol=1e-12)
        assert np.allclose(M0[np.ix_(t, t)], m * np.eye(3), rtol=1e-12, atol=1e-12)
    assert not np.array_equal(M, M0)
