# coopdyn.Client against a real coopdynd over LCM udpm on loopback (a private port, ttl=0): torque
# commands round-trip (the daemon's outputs carry our seq and apply our torque exactly), the outputs
# decode to arrays that Scene.evaluate reproduces bit for bit, loop statistics arrive; with the
# daemon's auth key, signed commands are applied and unsigned ones counted unauthenticated.
# Every wait is for an event, with a generous bound; nothing asserts a rate or a time.
import os
import subprocess
import tempfile

import numpy as np
import pytest

from conftest import SCENES

import coopdyn

KEY_HEX = "00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978"
SCENE = next(p for p in SCENES if p.stem == "two_puma_load")


def daemon(url, tmp, auth=False):
    args = [os.environ["COOPDYND"], "--scene", str(SCENE), "--lcm-url", url, "--rate", "200", "--duration", "60"]
    key = None
    if auth:
        key = os.path.join(tmp, "coopdyn.key")
        with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(KEY_HEX + "\n")
        cfg = os.path.join(tmp, "coopdynd.yaml")
        with open(cfg, "w") as f:
            f.write("auth:\n  key_file: %s\n" % key)
        args += ["--config", cfg]
    log = open(os.path.join(tmp, "daemon.log"), "w+")
    return subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT), key, log


def url(offset):
    return "udpm://239.255.76.67:%d?ttl=0" % (20000 + (os.getpid() * 13 + offset) % 30000)


def wait_applied(c, seq, tau, tries=2000):
    """The first output that says it applied command seq (or a later one of ours)."""
    for _ in range(tries):
        o = c.next_output(timeout=10.0)
        assert o is not None, "no output from the daemon within 10 s"
        if o["input"] == "command" and o["input_seq"] >= seq:
            return o
        c.publish_torque(tau)  # keep commanding: an expired command is not applied
    raise AssertionError("the daemon never applied our command")


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory() as d:
        yield d


def test_round_trip_through_daemon(tmp):
    u = url(0)
    d, _, log = daemon(u, tmp)
    try:
        with coopdyn.Client(u) as c:
            first = c.next_output(timeout=20.0)
            assert first is not None, "no output_t within 20 s"
            s = coopdyn.load_scene(SCENE)
            assert first["q_names"] == s.q_names and first["v_names"] == s.v_names
            assert list(first["wrenches"]) == s.wrench_names
            tau = {"arm1.q2": 2.5, "arm2.q3": -1.25}
            o = wait_applied(c, c.publish_torque(tau), tau)
            i, j = s.v_names.index("arm1.q2"), s.v_names.index("arm2.q3")
            assert o["tau"][i] == 2.5 and o["tau"][j] == -1.25
            # the daemon's evaluation at its state and torque: the same doubles here
            ev = s.evaluate(o["q"], o["v"], o["tau"])
            assert np.array_equal(ev.vdot, o["vdot"])
            for n in s.wrench_names:
                assert np.array_equal(ev.wrenches[n], o["wrenches"][n]), n
            assert o["status"] == ev.status and o["rank"] == ev.diagnostics["rank"]
            st = c.next_stats(timeout=20.0)
            while st is not None and st["accepted"] < 1:
                c.publish_torque({"arm1.q2": 2.5, "arm2.q3": -1.25})
                st = c.next_stats(timeout=20.0)
            assert st is not None and st["accepted"] >= 1 and st["rejected"] == 0
            assert c.counts()["outputs_received"] >= 2
            with pytest.raises(ValueError, match=r"tau\['arm1.q2'\] is not finite"):
                c.publish_torque({"arm1.q2": float("nan")})
    finally:
        d.terminate()
        d.wait(10)
        log.close()


def test_signed_commands(tmp):
    u = url(7)
    d, key, log = daemon(u, tmp, auth=True)
    try:
        with coopdyn.Client(u, key_file=key) as c:
            assert c.next_output(timeout=20.0) is not None
            o = wait_applied(c, c.publish_torque({"arm1.q2": 1.5}), {"arm1.q2": 1.5})
            assert o["tau"][o["v_names"].index("arm1.q2")] == 1.5
        with coopdyn.Client(u) as c:  # unsigned: refused
            assert c.next_output(timeout=20.0) is not None
            for _ in range(3):
                c.publish_torque({"arm1.q2": 9.0})
            st = c.next_stats(timeout=20.0)
            while st is not None and st["rejected_by_reason"]["unauthenticated"] < 1:
                c.publish_torque({"arm1.q2": 9.0})
                st = c.next_stats(timeout=20.0)
            assert st is not None and st["rejected_by_reason"]["unauthenticated"] >= 1
    finally:
        d.terminate()
        d.wait(10)
        log.close()
    with pytest.raises(ValueError, match=r"^key_file: "):
        coopdyn.Client(u, key_file=os.path.join(tmp, "missing.key"))
