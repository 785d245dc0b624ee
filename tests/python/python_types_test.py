"""The generated Python types (lcm-gen --python) against the daemon's C++ codec.

Each message is built and encoded in Python, decoded by the C++ codec (lcm_interop_helper decode: the
daemon's validating decoders for the inputs, decode_output / decode_stats for the outputs), and the
C++ values equal the Python ones field by field, doubles bit for bit. The inputs also go through the
decoders' checks: a torque over the scene's limit and a NaN are refused, names are mapped to the
scene's order. Only the standard library and the generated package (no lcm module).
"""
import math
import os
import random
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import interop  # noqa: E402
from interop import same  # noqa: E402

import coopdyn  # noqa: E402  (PYTHONPATH: the build tree's python/ or an installed site-packages)
from coopdyn import lcmlog  # noqa: E402
from coopdyn.lcmlog import components  # noqa: E402

SCENE = "two_puma_load"
# doubles that a text round trip would get wrong: -0.0, a subnormal, the largest, infinities, 0.1
ODD = [-0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 0.1, -1.0 / 3.0, math.pi * 1e-300]


class PythonTypes(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = interop.scene_info(SCENE)
        cls.tmp = tempfile.TemporaryDirectory(prefix="coopdyn-pytypes-")
        cls.rng = random.Random(14)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def decode(self, *msgs):
        """The C++ codec's view of Python-encoded messages, one dict per message."""
        files = []
        for i, m in enumerate(msgs):
            path = os.path.join(self.tmp.name, "%s_%d.bin" % (type(m).__name__, i))
            with open(path, "wb") as f:
                f.write(m.encode())
            files.append(path)
        return interop.helper("decode", interop.scene_path(SCENE), *files)

    def actuated(self):
        return [i for i, lim in enumerate(self.scene["tau_limit"]) if lim > 0]

    def test_package_needs_no_lcm_module(self):
        self.assertNotIn("lcm", sys.modules)
        for t in (coopdyn.output_t, coopdyn.output_v4_t, coopdyn.output_v3_t, coopdyn.output_v2_t, coopdyn.output_v1_t,
                  coopdyn.wrench_t, coopdyn.torque_command_t,
                  coopdyn.measured_state_t, coopdyn.control_t, coopdyn.loop_stats_t):
            m = t()
            self.assertEqual(t.decode(m.encode()).encode(), m.encode(), t.__name__)

    def test_torque_command_by_name(self):
        names = self.scene["v_names"]
        idx = self.actuated()[::-1]  # named, in reverse order: the decoder maps names to the scene's order
        m = coopdyn.torque_command_t()
        m.utime = interop_now()
        m.seq = 2 ** 40 + 3
        m.names = [names[i] for i in idx]
        m.num_names = len(m.names)
        m.tau = [self.rng.uniform(-0.5, 0.5) * self.scene["tau_limit"][i] for i in idx]
        m.tau[0] = -0.0
        m.num_torques = len(m.tau)
        (d,) = self.decode(m)
        self.assertEqual(d["type"], "torque_command_t")
        self.assertEqual(d["reject"], "")
        self.assertEqual((d["utime"], d["seq"]), (m.utime, m.seq))
        want = [0.0] * len(names)
        for i, t in zip(idx, m.tau):
            want[i] = t
        same(self, want, d["tau"], "tau")

    def test_torque_command_checks(self):
        i = self.actuated()[0]
        over = coopdyn.torque_command_t()
        over.utime, over.seq = interop_now(), 1
        over.names, over.num_names = [self.scene["v_names"][i]], 1
        over.tau, over.num_torques = [1.5 * self.scene["tau_limit"][i]], 1
        nan = coopdyn.torque_command_t()
        nan.utime, nan.seq = interop_now(), 2
        nan.names, nan.num_names = [self.scene["v_names"][i]], 1
        nan.tau, nan.num_torques = [float("nan")], 1
        unknown = coopdyn.torque_command_t()
        unknown.utime, unknown.seq = interop_now(), 3
        unknown.names, unknown.num_names = ["no_such_joint"], 1
        unknown.tau, unknown.num_torques = [0.0], 1
        got = [d["reject"] for d in self.decode(over, nan, unknown)]
        self.assertEqual(got, ["over_tau_limit", "nonfinite", "unknown_name"])

    def test_measured_state(self):
        s = self.scene
        m = coopdyn.measured_state_t()
        m.utime, m.seq = interop_now(), 11
        m.num_q, m.q = len(s["q0"]), [x + self.rng.uniform(-1e-3, 1e-3) for x in s["q0"]]
        m.num_v, m.v = len(s["v0"]), [self.rng.uniform(-1, 1) for _ in s["v0"]]
        m.tau = [0.0] * m.num_v
        for i in self.actuated():
            m.tau[i] = self.rng.uniform(-0.5, 0.5) * s["tau_limit"][i]
        m.q[0] = ODD[6]
        k = len(s["wrench_names"]) - 1
        m.num_wrenches, m.wrench_names = 1, [s["wrench_names"][k]]
        m.wrench = [ODD[:6]]
        (d,) = self.decode(m)
        self.assertEqual(d["reject"], "")
        self.assertEqual((d["utime"], d["seq"]), (m.utime, m.seq))
        same(self, m.q, d["q"], "q")
        same(self, m.v, d["v"], "v")
        same(self, m.tau, d["tau"], "tau")
        self.assertEqual(d["has_wrench"], [1 if j == k else 0 for j in range(len(s["wrench_names"]))])
        same(self, m.wrench[0], d["wrench"][k], "wrench")

    def test_control_reset_to_state(self):
        s = self.scene
        m = coopdyn.control_t()
        m.utime, m.seq, m.action = interop_now(), 5, coopdyn.control_t.ACTION_RESET_TO_STATE
        m.nq, m.q = len(s["q0"]), list(s["q0"])
        m.nv, m.v = len(s["v0"]), [self.rng.uniform(-1, 1) for _ in s["v0"]]
        (d,) = self.decode(m)
        self.assertEqual(d["reject"], "")
        self.assertEqual((d["utime"], d["seq"], d["action"], d["has_state"]), (m.utime, m.seq, m.action, 1))
        same(self, m.q, d["q"], "q")
        same(self, m.v, d["v"], "v")

    def test_output_every_field(self):
        r = self.rng
        m = coopdyn.output_t()
        m.version = coopdyn.output_t.VERSION
        m.utime, m.tick, m.sim_time = 1764750000123456, 2 ** 33 + 1, 12.345678901234567
        m.mode, m.status, m.reason, m.input = 1, 1, coopdyn.output_t.REASON_CLOSURE, coopdyn.output_t.INPUT_STATE
        m.input_seq, m.input_utime, m.paused = 77, 1764750000000001, 1
        m.control_seq, m.control_action, m.control_result = 9, 2, coopdyn.output_t.CONTROL_REJECTED_STATE
        m.state_fitted, m.fit_iterations = 3, 4
        m.closure, m.closure_constraint = [ODD[1], ODD[2], 1e-9, -0.0], [-1, 0, 1, 32767]
        m.constraint_names = ["weld_a", "weld \"b\""]
        m.num_constraints = 2
        m.rows, m.rank, m.indeterminate, m.condition, m.residual = 24, 21, 3, -1.0, ODD[6]
        nw = 3
        m.num_wrenches = nw
        m.wrench_names, m.wrench_frames, m.wrench_by = ["arm1.ee", "arm2.base", "fl"], ["a", "b", "fl.contact"], \
            ["load.arm1", "world", "ground"]
        m.wrench_kind = [0, 1, 2]
        m.wrench = [wrench([r.uniform(-100, 100) for _ in range(6)]) for _ in range(nw)]
        m.wrench[2] = wrench(ODD[:6])
        m.constrained_mask, m.indeterminate_mask, m.wrench_measured = [63, 7, 56], [0, 1, 56], [1, 0, 0]
        m.wrench_residual = [wrench([r.gauss(0, 1) for _ in range(6)]) for _ in range(nw)]
        m.sigma_source = coopdyn.output_t.SIGMA_TAU
        m.wrench_sigma = [wrench([abs(r.gauss(0, 1)) for _ in range(6)]) for _ in range(nw)]
        m.joint_losses, m.friction_resting = coopdyn.output_t.JOINT_LOSSES_COMPENSATED, 3
        m.wrench_bound = [wrench([abs(r.gauss(0, 1)) for _ in range(6)]) for _ in range(nw)]
        m.num_free, m.free_class = 2, [coopdyn.output_t.FREE_FORCE, coopdyn.output_t.FREE_MIXED]
        m.free_direction = [[wrench([r.uniform(-1, 1) for _ in range(6)]) for _ in range(nw)] for _ in range(2)]
        m.contact_status, m.num_contacts = 1, 2
        m.contact_names, m.contact_normal = ["fl", "fr"], [3210.193, -1.0]
        m.contact_friction_needed, m.contact_utilisation, m.contact_state = [0.5, -1.0], [0.5 / 0.85, -1.0], [1, 2]
        m.num_stresses, m.stress_names, m.stress = 1, ["lock"], [float("inf")]
        m.nq, m.q_names, m.q = 2, ["j1", "j2"], [0.3, -0.7]
        m.nv, m.v_names = 2, ["j1", "j2"]
        m.v, m.tau, m.vdot = [1.0, 2.0], [float("-inf"), 3.0], [r.gauss(0, 1e3), 0.0]
        m.limits, m.limit_mask = coopdyn.output_t.LIMIT_POSITION | coopdyn.output_t.LIMIT_EFFORT, \
            [coopdyn.output_t.LIMIT_EFFORT, coopdyn.output_t.LIMIT_POSITION]
        (d,) = self.decode(m)
        self.assertEqual(d["reject"], "")
        o = d["message"]
        self.assertEqual(set(o), set(m.__slots__) - {"version", "num_constraints", "num_wrenches", "num_free",
                                                      "num_contacts", "num_stresses", "nq", "nv"})
        for k in o:
            same(self, getattr(m, k), o[k], k)
        # the same message with the limits unknown (-1: what the layout of version 4 decodes to)
        nolimits = coopdyn.output_t.decode(m.encode())
        nolimits.limits, nolimits.limit_mask = -1, [-1, -1]
        (dl,) = self.decode(nolimits)
        v4 = coopdyn.output_v4_t()
        for k in v4.__slots__:
            setattr(v4, k, getattr(m, k))
        v4.version = 4
        self.assertNotEqual(v4.encode()[:8], m.encode()[:8])
        (d4,) = self.decode(v4)
        self.assertEqual(d4["reject"], "")
        self.assertEqual(d4["message"], dl["message"])
        self.assertIsInstance(lcmlog.decode(v4.encode()), coopdyn.output_v4_t)
        # ... and without the friction bound (what the layout of version 3 decodes to)
        nobound = coopdyn.output_t.decode(nolimits.encode())
        nobound.joint_losses, nobound.friction_resting = coopdyn.output_t.JOINT_LOSSES_NONE, 0
        nobound.wrench_bound = [wrench([0.0] * 6) for _ in range(nw)]
        (db,) = self.decode(nobound)
        v3 = coopdyn.output_v3_t()
        for k in v3.__slots__:
            setattr(v3, k, getattr(m, k))
        v3.version = 3
        self.assertNotEqual(v3.encode()[:8], m.encode()[:8])
        (d3,) = self.decode(v3)
        self.assertEqual(d3["reject"], "")
        self.assertEqual(d3["message"], db["message"])
        self.assertIsInstance(lcmlog.decode(v3.encode()), coopdyn.output_v3_t)
        # ... and without sigma (what the layouts before version 3 decode to)
        nosig = coopdyn.output_t.decode(nobound.encode())
        nosig.sigma_source, nosig.wrench_sigma = coopdyn.output_t.SIGMA_NONE, [wrench([0.0] * 6) for _ in range(nw)]
        (d0,) = self.decode(nosig)
        # in the layout logs had in version 2 (output_v2_t's fingerprint: no sigma)
        v2 = coopdyn.output_v2_t()
        for k in v2.__slots__:
            setattr(v2, k, getattr(m, k))
        v2.version = 2
        self.assertNotEqual(v2.encode()[:8], m.encode()[:8])
        (d2,) = self.decode(v2)
        self.assertEqual(d2["reject"], "")
        self.assertEqual(d2["message"], d0["message"])
        self.assertIsInstance(lcmlog.decode(v2.encode()), coopdyn.output_v2_t)
        # the same message in the layout logs had before version 2 (output_v1_t's fingerprint, that of
        # the old output_t: wrenches as 6-arrays) decodes in C++ to the same values
        old = coopdyn.output_v1_t()
        for k in old.__slots__:
            v = getattr(m, k)
            if k in ("wrench", "wrench_residual"):
                v = [components(w) for w in v]
            elif k == "free_direction":
                v = [[components(w) for w in d] for d in v]
            setattr(old, k, v)
        self.assertNotEqual(old.encode()[:8], m.encode()[:8])
        (d1,) = self.decode(old)
        self.assertEqual(d1["reject"], "")
        self.assertEqual(d1["message"], d0["message"])
        self.assertIsInstance(lcmlog.decode(old.encode()), coopdyn.output_v1_t)

    def test_loop_stats(self):
        m = coopdyn.loop_stats_t()
        for k in m.__slots__:
            if isinstance(getattr(m, k), float):
                setattr(m, k, self.rng.uniform(0, 500))
            elif isinstance(getattr(m, k), int):
                setattr(m, k, self.rng.randrange(0, 2 ** 50))
        m.period_us = 1000.0
        keys = ["malformed", "wrong_count", "unknown_name", "duplicate_name", "nonfinite", "over_tau_limit",
                "stale_utime", "future_utime", "unactuated", "incomplete", "not_locked", "over_target_limit",
                "unauthenticated", "bad_mac", "replayed"]
        m.num_reject_reasons, m.reject_reasons = len(keys), keys
        m.rejected_by_reason = [self.rng.randrange(0, 1000) for _ in keys]
        (d,) = self.decode(m)
        self.assertEqual(d["reject"], "")
        o = d["message"]
        for k in o:
            if k in ("lateness_us", "compute_us"):
                py = [getattr(m, "%s_%s_us" % (k[:-3], p)) for p in ("p50", "p99", "p999", "max")]
            else:
                py = getattr(m, k)
            same(self, py, o[k], k)


def wrench(c):
    w = coopdyn.wrench_t()
    w.mx, w.my, w.mz, w.fx, w.fy, w.fz = c
    return w


def interop_now():
    import time
    return int(time.time() * 1e6)


if __name__ == "__main__":
    unittest.main()
