"""One chunk of a study, computed where Dask puts it: rows of numbers from the spec and the chunk index.

kind hold: at each sample's state and load mass, the holding torques (dynamics/holding_torque.h: least
squares of the torques as fractions of their limits, not clamped), each actuated joint's utilisation
|tau| / limit, feasible (every utilisation <= 1) and the joint that binds (largest utilisation), the
hands' wrenches when held so, and the internal force norm.
kind payload: the heaviest load the arms hold within their limits at each pose. At rest the bias is
gravity, affine in the load mass, and the holding torque is linear in the bias, so
tau(m) = tau(0) + m (tau(1) - tau(0)) exactly: the payload is the smallest m at which a joint reaches
its limit, from two evaluations (m = 0 and 1 kg); the wrenches are affine in m alike.
"""
import math

import numpy as np

from . import samples, scenes


def columns(spec):
    s = spec.scene
    act = [i for i, L in enumerate(s.tau_limit) if L > 0]
    joints = [s.v_names[i] for i in act]
    hands = hand_names(s)
    cols = ["sample"] + [v.name for v in spec.variables] + ["status"]
    if spec.kind == "evaluate":
        return cols + ["feasible", "binding", "util_max"] + [f"{h}.{c}" for h in hands
                                                              for c in ("mx", "my", "mz", "fx", "fy", "fz")]
    if spec.kind == "payload":
        cols += ["payload", "binding", "feasible_empty", "util_empty"]
    else:
        cols += ["feasible", "binding", "util_max"]
    cols += [f"tau.{j}" for j in joints] + [f"util.{j}" for j in joints]
    cols += [f"{h}.{c}" for h in hands for c in ("mx", "my", "mz", "fx", "fy", "fz")] + ["internal_force"]
    if any(v.name == "load.mass_error" for v in spec.variables):
        cols += ["wrench_shift"]
    return cols


def hand_names(s):
    """The wrenches the arms put on the load: '<arm>.ee' (tip wrenches at the end effectors)."""
    return [w for w in s.wrench_names if w.endswith(".ee") and w in s.frame_names]


def _internal_force(s, q, wrenches, hands):
    """sqrt(sum_i |f_i - mean f|^2) over the hands' forces in world axes (N): the part of the hand
    forces that squeezes the load rather than carries it."""
    f = np.array([s.frame_pose(h, q)[:3, :3] @ wrenches[h][3:] for h in hands])
    return float(np.sqrt(np.sum((f - f.mean(axis=0)) ** 2)))


def _state(spec, s, values, r):
    offset = np.array([values.get(f"load.{a}", np.zeros(r + 1))[r] for a in "xyz"])
    if any(f"load.{a}" in values for a in "xyz"):
        q, err = scenes.load_moved(s, offset)
        return q, ("ok" if err < 1e-9 else "unreachable")
    q = np.array(s.q0)
    for name, col in values.items():
        if name in s.q_names:
            q[s.q_names.index(name)] = col[r]
    return q, "ok"


def run_chunk(spec, k):
    """The rows of chunk k: a list of tuples (float; int for the index and 0/1 flags; str for status
    and binding), NaN where a sample has no value (status says why)."""
    base = spec.scene
    idx, values = samples.chunk_values(spec, k)
    act = [i for i, L in enumerate(base.tau_limit) if L > 0]
    limit = np.asarray(base.tau_limit)[act]
    hands = hand_names(base)
    names = [v.name for v in spec.variables]
    ncol = len(columns(spec))
    if spec.kind == "evaluate":
        return _evaluate_chunk(spec, idx, values, act, limit, hands)
    rows = []
    for r, i in enumerate(idx):
        head = [int(i)] + [float(values[n][r]) for n in names]
        q, status = _state(spec, base, values, r)
        if status != "ok":
            rows.append(tuple(head + [status] + [math.nan] * (ncol - len(head) - 1)))
            continue
        try:
            if spec.kind == "payload":
                rows.append(tuple(head + _payload_sample(spec, q, act, limit, hands)))
            else:
                rows.append(tuple(head + _hold_sample(spec, values, r, q, act, limit, hands)))
        except ValueError:  # the bindings' refusal of a state (a singular mass matrix): no value
            rows.append(tuple(head + ["invalid"] + [math.nan] * (ncol - len(head) - 1)))
    return rows


def _hold_at(s, q, tau):
    b = s.evaluate_batch(q[None, :], np.zeros((1, s.nv)), tau[None, :])
    return {n: b["wrenches"][n][0] for n in b["wrenches"]}, b["status"][0]


def _hold_sample(spec, values, r, q, act, limit, hands):
    m = values["load.mass"][r] if "load.mass" in values else None
    s = scenes.scene(spec.scene_path, m)
    tau = s.holding_torque(q, clamp=False)
    util = np.abs(tau[act]) / limit
    w, st = _hold_at(s, q, tau)
    out = ["ok" if st in ("ok", 0) else str(st), int(np.all(util <= 1.0)),
           s.v_names[act[int(np.argmax(util))]], float(np.max(util))]
    out += [float(x) for x in tau[act]] + [float(x) for x in util]
    out += [float(x) for h in hands for x in w[h]] + [_internal_force(s, q, w, hands)]
    if "load.mass_error" in values:
        m_true = scenes.scene_mass(spec.scene_path) if m is None else m
        model = scenes.scene(spec.scene_path, m_true * (1.0 + values["load.mass_error"][r]))
        w_est, _ = _hold_at(model, q, tau)
        out.append(max(float(np.linalg.norm(w_est[h][3:] - w[h][3:])) for h in hands))
    return out


def payload_line(a, b, limit):
    """(payload kg, binding index) for torques a + m b with |.| <= limit; (0, worst) if even m = 0
    exceeds a limit, (inf, -1) if no joint is loaded by the mass."""
    if np.any(np.abs(a) > limit):
        return 0.0, int(np.argmax(np.abs(a) / limit))
    with np.errstate(divide="ignore", invalid="ignore"):
        m = np.where(b > 0, (limit - a) / b, np.where(b < 0, (-limit - a) / b, np.inf))
    j = int(np.argmin(m))
    return (float(m[j]), j) if math.isfinite(m[j]) else (math.inf, -1)


def _payload_sample(spec, q, act, limit, hands):
    s0, s1 = scenes.scene(spec.scene_path, 0.0), scenes.scene(spec.scene_path, 1.0)
    t0, t1 = s0.holding_torque(q, clamp=False), s1.holding_torque(q, clamp=False)
    a, b = t0[act], t1[act] - t0[act]
    m, j = payload_line(a, b, limit)
    if not math.isfinite(m):
        return ["unbounded"] + [math.nan] * (3 + 2 * len(act) + 6 * len(hands) + 1)
    tau = t0 + m * (t1 - t0)
    w0, _ = _hold_at(s0, q, t0)
    w1, _ = _hold_at(s1, q, t1)
    w = {h: w0[h] + m * (w1[h] - w0[h]) for h in hands}
    util0 = np.abs(a) / limit
    out = ["ok", m, s0.v_names[act[j]], int(np.all(util0 <= 1.0)), float(np.max(util0))]
    out += [float(x) for x in tau[act]] + [float(x) for x in np.abs(tau[act]) / limit]
    out += [float(x) for h in hands for x in w[h]] + [_internal_force(s0, q, w, hands)]
    return out


def _evaluate_chunk(spec, idx, values, act, limit, hands):
    """kind evaluate: the chunk's states and torques in one Scene.evaluate_batch (GIL released), the
    torques' utilisation of their limits and the hands' wrenches (in the hand frames)."""
    s = spec.scene
    n = len(idx)
    Q = np.tile(np.asarray(s.q0), (n, 1))
    TAU = np.zeros((n, s.nv))
    for name, col in values.items():
        if name.startswith("tau."):
            TAU[:, s.v_names.index(name[4:])] = col
        else:
            Q[:, s.q_names.index(name)] = col
    b = s.evaluate_batch(Q, np.tile(np.asarray(s.v0), (n, 1)), TAU)
    util = np.abs(TAU[:, act]) / limit
    v_names = s.v_names
    binding = [v_names[act[j]] for j in np.argmax(util, axis=1)]
    feasible = np.all(util <= 1.0, axis=1).astype(int).tolist()
    status = ["ok" if st in ("ok", 0) else str(st) for st in b["status"]]
    head = np.column_stack([values[v.name] for v in spec.variables]).tolist() if spec.variables else [[]] * n
    W = np.concatenate([b["wrenches"][h] for h in hands], axis=1).tolist() if hands else [[]] * n
    umax = np.max(util, axis=1).tolist()
    return [tuple([int(idx[r])] + head[r] + [status[r], feasible[r], binding[r], umax[r]] + W[r]) for r in range(n)]
