"""The scene a sample needs: the study's scene with the load's mass edited, and the arms' joints that
keep every arm base where the scene has it when the load moves (inverse kinematics).

Scenes are cached per process (a Scene holds C++ workspaces and is not pickled between workers).
"""
import math
import os

import numpy as np
import yaml

import coopdyn

_scenes = {}
_PATH_KEYS = ("file", "urdf", "srdf", "mesh")


def _absolute_paths(node, base):
    if isinstance(node, dict):
        for k, v in node.items():
            if k in _PATH_KEYS and isinstance(v, str) and not os.path.isabs(v):
                node[k] = os.path.normpath(os.path.join(base, v))
            else:
                _absolute_paths(v, base)
    elif isinstance(node, list):
        for v in node:
            _absolute_paths(v, base)


def scene(path, mass=None):
    """The scene of `path`, its load's mass set to `mass` kg (None: as the file says); the box's
    inertia scales with the mass (same shape and size)."""
    key = (path, None if mass is None else float(mass))
    if key not in _scenes:
        if mass is None:
            _scenes[key] = coopdyn.load_scene(path)
        else:
            with open(path) as f:
                data = yaml.safe_load(f)
            load = data["load"]
            m0 = float(load.get("mass", 0.0))
            if "inertia" in load and m0 > 0:
                load["inertia"] = [float(x) * float(mass) / m0 for x in load["inertia"]]
            load["mass"] = float(mass)
            _absolute_paths(data, os.path.dirname(path))
            _scenes[key] = coopdyn.load_scene(yaml.safe_dump(data))
        if len(_scenes) > 256:  # a random mass per sample: keep the cache bounded
            _scenes.pop(next(iter(_scenes)))
    return _scenes[key]


def scene_mass(path):
    with open(path) as f:
        return float(yaml.safe_load(f)["load"].get("mass", 0.0))


def arms(s):
    """{arm: (its base frame, its q indices, its v indices)} of a load-rooted scene."""
    out = {}
    for i, n in enumerate(s.q_names):
        arm = n.split(".")[0]
        if arm != "load":
            out.setdefault(arm, (f"{arm}.base", [], []))[1].append(i)
    for arm, (_, qi, vi) in out.items():
        vi.extend(s.v_names.index(s.q_names[i]) for i in qi)
    return out


def _rotation_error(R_target, R):
    """Angle-axis vector (world axes, rad) that turns R into R_target."""
    E = R_target @ R.T
    c = max(-1.0, min(1.0, (np.trace(E) - 1.0) / 2.0))
    w = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    a = math.acos(c)
    return w if a < 1e-12 else w * (a / math.sin(a))


def load_moved(s, offset, tol=1e-12, iters=60):
    """q with the load translated by `offset` (m, world axes) and each arm's joints solved (Newton on
    the base frame's pose, from the scene's own q0) so its base stays welded where it is in q0.
    (q, worst pose error) ; the error is m or rad, > 1e-9 when the pose is out of reach."""
    q0 = np.array(s.q0)
    q = q0.copy()
    q[0:3] += offset
    worst = 0.0
    for arm, (frame, qi, vi) in arms(s).items():
        X0 = s.frame_pose(frame, q0)
        err = math.inf
        for _ in range(iters):
            X = s.frame_pose(frame, q)
            e = np.concatenate([_rotation_error(X0[:3, :3], X[:3, :3]), X0[:3, 3] - X[:3, 3]])
            err = float(np.max(np.abs(e)))
            if err < tol:
                break
            J = s.jacobian(frame, q)[:, vi]
            q[qi] += np.linalg.lstsq(J, e, rcond=None)[0]
        worst = max(worst, err)
    return q, worst
