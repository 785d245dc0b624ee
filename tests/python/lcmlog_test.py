"""coopdyn.lcmlog, the pure-Python LCM log reader, on a log the daemon's loop wrote.

lcm_interop_helper write-log runs coopdynd's loop (runtime::ServiceLoop, its OutputEncoder and
StatsEncoder) for 40 ticks with a bus that records every published message with LCM's C event-log
API, and a torque command sent to the loop; it also writes what the C++ codec decodes from each event.
Here the log is read back in Python and decoded with the generated types: the events (number,
timestamp, channel) and every field of every message equal the C++ values, doubles bit for bit, and
re-encoding in Python gives the logged bytes back. Damaged logs give errors naming the file and the
byte. The example log_wrenches.py prints the same doubles by name.
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import interop  # noqa: E402
from interop import same  # noqa: E402

from coopdyn import lcmlog  # noqa: E402
import coopdyn  # noqa: E402

EXAMPLES = os.path.join(interop.SOURCE_DIR, "clients", "python", "examples")


class LcmLog(unittest.TestCase):
    logs = {}

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="coopdyn-lcmlog-")
        # two_puma_load: the wrench outputs of the two arms; four_wheel_car: contacts and free directions
        for scene in ("two_puma_load", "four_wheel_car"):
            log = os.path.join(cls.tmp.name, scene + ".lcmlog")
            expect = os.path.join(cls.tmp.name, scene + ".json")
            interop.helper("write-log", interop.scene_path(scene), log, expect, 40)
            with open(expect) as f:
                cls.logs[scene] = (log, json.load(f)["events"])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_every_event_and_field_equals_the_cpp_side(self):
        for scene, (log, want) in self.logs.items():
            got = list(lcmlog.read(log))
            self.assertEqual(len(got), len(want), scene)
            kinds = {}
            for e, w in zip(got, want):
                where = "%s event %d" % (scene, w["eventnum"])
                self.assertEqual((e.eventnum, e.timestamp, e.channel), (w["eventnum"], w["timestamp"], w["channel"]),
                                 where)
                m = lcmlog.decode(e.data)
                self.assertIsNotNone(m, where)
                self.assertEqual(m.encode(), e.data, where + ": Python re-encodes the logged bytes")
                kinds[type(m).__name__] = kinds.get(type(m).__name__, 0) + 1
                msg = w["message"]
                if w["type"] == "output_t":
                    self.assertIsInstance(m, coopdyn.output_t, where)
                    self.assertEqual(len(msg), 55)  # every field the C++ side decodes (sigma: 3; bound: 4; limits: 5)
                    for k, v in msg.items():
                        same(self, getattr(m, k), v, "%s: %s" % (where, k))
                elif w["type"] == "loop_stats_t":
                    self.assertIsInstance(m, coopdyn.loop_stats_t, where)
                    for k, v in msg.items():
                        if k in ("lateness_us", "compute_us"):
                            py = [getattr(m, "%s_%s_us" % (k[:-3], p)) for p in ("p50", "p99", "p999", "max")]
                        else:
                            py = getattr(m, k)
                        same(self, py, v, "%s: %s" % (where, k))
                else:
                    self.assertIsInstance(m, coopdyn.torque_command_t, where)
                    self.assertEqual((m.utime, m.seq, m.names), (msg["utime"], msg["seq"], msg["names"]), where)
                    same(self, m.tau, msg["tau"], where + ": tau")
            self.assertEqual(kinds, {"output_t": 40, "loop_stats_t": 4, "torque_command_t": 1}, scene)
            # what the test is about: the physics is there (non-zero wrenches, the command applied)
            outs = [lcmlog.decode(e.data) for e in got if e.channel == "COOPDYN_OUTPUT"]
            self.assertTrue(any(abs(x) > 1 for x in lcmlog.components(outs[-1].wrench[0])), scene)
            self.assertEqual({o.version for o in outs}, {coopdyn.output_t.VERSION}, scene)
            self.assertEqual([o.input_seq for o in outs[-3:]], [7, 7, 7], scene)
        car = [lcmlog.decode(e.data) for e in lcmlog.read(self.logs["four_wheel_car"][0], "COOPDYN_OUTPUT")]
        self.assertGreater(car[0].num_free, 0)
        self.assertEqual(car[0].contact_names, ["fl", "fr", "rl", "rr"])

    def test_channel_filter(self):
        log, want = self.logs["two_puma_load"]
        got = [e.eventnum for e in lcmlog.read(log, channel="COOPDYN_STATS")]
        self.assertEqual(got, [w["eventnum"] for w in want if w["channel"] == "COOPDYN_STATS"])

    def test_damaged_logs_name_the_file_and_byte(self):
        log, want = self.logs["two_puma_load"]
        with open(log, "rb") as f:
            data = f.read()
        events = list(lcmlog.read(log))
        last = len(data) - (lcmlog.HEADER_BYTES + len(events[-1].channel) + len(events[-1].data))
        cut = os.path.join(self.tmp.name, "cut.lcmlog")
        with open(cut, "wb") as f:
            f.write(data[:-5])
        with self.assertRaises(lcmlog.LogError) as e:
            list(lcmlog.read(cut))
        self.assertEqual(str(e.exception), "%s: byte %d: event %d cut short (%d of %d bytes)" % (
            cut, last, events[-1].eventnum, len(events[-1].channel) + len(events[-1].data) - 5,
            len(events[-1].channel) + len(events[-1].data)))
        with open(cut, "wb") as f:
            f.write(data[:10])
        with self.assertRaisesRegex(lcmlog.LogError, "^%s: byte 0: truncated record header" % cut):
            list(lcmlog.read(cut))
        scene = interop.scene_path("two_puma_load")
        with self.assertRaisesRegex(lcmlog.LogError, "^%s: byte 0: not an LCM log record" % scene):
            list(lcmlog.read(scene))
        # a good prefix is read before the error: the reader is a stream
        with open(cut, "wb") as f:
            lcmlog.write(f, events[:3])
            f.write(b"\x00" * 30)
        n = 0
        at = sum(lcmlog.HEADER_BYTES + len(e.channel) + len(e.data) for e in events[:3])
        with self.assertRaisesRegex(lcmlog.LogError, "^%s: byte %d: not an LCM log record" % (cut, at)):
            for _ in lcmlog.read(cut):
                n += 1
        self.assertEqual(n, 3)

    def test_inputs_recorded_before_the_mac_still_decode(self):
        # the committed golden log's command (pre-MAC fingerprint) and one re-encoded without mac_len
        path = os.path.join(os.environ["COOPDYN_SOURCE_DIR"], "tests", "golden", "two_puma_load.lcmlog")
        cmds = [lcmlog.decode(e.data) for e in lcmlog.read(path, "COOPDYN_COMMAND")]
        self.assertEqual(len(cmds), 5)
        self.assertTrue(all(isinstance(c, coopdyn.torque_command_t) and c.mac_len == 0 for c in cmds))
        self.assertEqual([c.seq for c in cmds], sorted(c.seq for c in cmds))
        m = coopdyn.control_t()
        m.utime, m.seq, m.action, m.nq, m.q, m.nv, m.v = 7, 8, coopdyn.control_t.ACTION_PAUSE, 0, [], 0, []
        old = bytes.fromhex("489f6be38cd3846e") + m.encode()[8:-4]
        back = lcmlog.decode(old)
        self.assertEqual((back.utime, back.seq, back.action, back.mac_len), (7, 8, coopdyn.control_t.ACTION_PAUSE, 0))

    def test_loop_stats_recorded_before_the_control_counts_still_decode(self):
        # loop_stats_t before limit_ticks* (and before outputs_dropped, controls_*, inputs_malformed): those
        # fields read as 0
        m = coopdyn.loop_stats_t()
        m.tick, m.commands_rejected, m.inputs_malformed, m.controls_bad_mac, m.outputs_dropped = 50, 5, 11, 2, 13
        m.limit_ticks, m.limit_ticks_velocity = 9, 8
        m.num_reject_reasons, m.reject_reasons, m.rejected_by_reason = 1, ["bad_mac"], [5]
        for old, cut in (("fd6321dfc5613009", 4), ("5f3a349535103d01", 5), ("48bcc81f9a071c5a", 11),
                         ("7f11746fd02903b9", 12)):
            back = lcmlog.decode(bytes.fromhex(old) + m.encode()[8:-8 * cut])
            self.assertIsInstance(back, coopdyn.loop_stats_t, old)
            self.assertEqual((back.tick, back.commands_rejected, back.limit_ticks, back.limit_ticks_velocity),
                             (50, 5, 0, 0), old)
            self.assertEqual(back.outputs_dropped, 13 if cut == 4 else 0, old)
            self.assertEqual(back.controls_bad_mac, 2 if cut <= 5 else 0, old)
            self.assertEqual(back.inputs_malformed, 0 if cut == 12 else 11, old)

    def test_write_read_identity(self):
        log, _ = self.logs["four_wheel_car"]
        copy = os.path.join(self.tmp.name, "copy.lcmlog")
        with open(copy, "wb") as f:
            lcmlog.write(f, lcmlog.read(log))
        with open(log, "rb") as a, open(copy, "rb") as b:
            self.assertEqual(a.read(), b.read())

    def test_coopdyn_log_reads_logs_of_both_output_versions(self):
        # the daemon's log rewritten with every output_t in the layout before version 2 (output_v1_t):
        # coopdyn log writes the same CSVs from both, byte for byte
        log, want = self.logs["four_wheel_car"]
        old_log = os.path.join(self.tmp.name, "v1.lcmlog")
        events = []
        for e in lcmlog.read(log):
            m = lcmlog.decode(e.data)
            if isinstance(m, coopdyn.output_t):
                old = coopdyn.output_v1_t()
                for k in old.__slots__:
                    v = getattr(m, k)
                    if k in ("wrench", "wrench_residual"):
                        v = [lcmlog.components(w) for w in v]
                    elif k == "free_direction":
                        v = [[lcmlog.components(w) for w in d] for d in v]
                    setattr(old, k, v)
                self.assertNotEqual(old.encode()[:8], e.data[:8])
                e = e._replace(data=old.encode())
            events.append(e)
        with open(old_log, "wb") as f:
            lcmlog.write(f, events)
        self.assertIsInstance(lcmlog.decode(next(lcmlog.read(old_log, "COOPDYN_OUTPUT")).data), coopdyn.output_v1_t)
        csv = {}
        for name, path in (("new", log), ("old", old_log)):
            out = os.path.join(self.tmp.name, name + "_csv")
            r = subprocess.run([os.environ["COOPDYN"], "log", "--in", path, "--out", out, "--no-plot"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(os.path.join(out, "COOPDYN_OUTPUT.csv")) as f:
                csv[name] = f.read()
        # the same but for the joint limits, which the old layout lacks: -1 (unknown) there
        def split(text, keep):
            rows = [line.split(",") for line in text.splitlines()]
            head = next(r for r in rows if not r[0].startswith("#"))
            lim = [i for i, h in enumerate(head) if h == "limits" or h.startswith("limit:")]
            return [[c for i, c in enumerate(r) if (i in lim) == keep] if len(r) == len(head) else r for r in rows]
        self.assertEqual(split(csv["old"], False), split(csv["new"], False))
        old_limits, new_limits = split(csv["old"], True), split(csv["new"], True)
        head = next(r for r in old_limits if r and r[0] == "limits")
        self.assertIn("limit:fl_spin", head)
        self.assertEqual({c for r in old_limits[old_limits.index(head) + 1:] for c in r}, {"-1"})
        self.assertEqual({c for r in new_limits[new_limits.index(head) + 1:] for c in r}, {"0"})
        self.assertIn("fl.fz", csv["new"])
        self.assertGreaterEqual(csv["new"].count("\n"), 41)

    def test_log_wrenches_example_prints_the_doubles_by_name(self):
        log, want = self.logs["two_puma_load"]
        r = subprocess.run([sys.executable, "-B", os.path.join(EXAMPLES, "log_wrenches.py"), log, "--wrench", "arm2.ee"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        lines = r.stdout.splitlines()
        self.assertEqual(lines[0], "sim_time_s name frame by mx_N*m my_N*m mz_N*m fx_N fy_N fz_N")
        outs = [w["message"] for w in want if w["type"] == "output_t"]
        self.assertEqual(len(lines) - 1, len(outs))
        for line, o in zip(lines[1:], outs):
            f = line.split()
            k = o["wrench_names"].index("arm2.ee")
            self.assertEqual(f[1:4], ["arm2.ee", o["wrench_frames"][k], o["wrench_by"][k]])
            same(self, float(f[0]), o["sim_time"], "sim_time")
            same(self, [float(x) for x in f[4:]], o["wrench"][k], "arm2.ee")
        r = subprocess.run([sys.executable, "-B", os.path.join(EXAMPLES, "log_wrenches.py"), log, "--wrench", "nope"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        self.assertEqual(r.returncode, 1)
        self.assertIn("no output_t wrenches on COOPDYN_OUTPUT named nope (the log has arm1.ee", r.stderr)
        # --plot: a PNG where matplotlib is installed, else an error saying what to install
        png = os.path.join(self.tmp.name, "wrenches.png")
        r = subprocess.run([sys.executable, "-B", os.path.join(EXAMPLES, "log_wrenches.py"), log, "--plot", png,
                            "--wrench", "arm1.ee"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, universal_newlines=True)
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            self.assertEqual(r.returncode, 1)
            self.assertIn("--plot needs matplotlib (Debian: apt install python3-matplotlib)", r.stderr)
        else:
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(png, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")


if __name__ == "__main__":
    unittest.main()
