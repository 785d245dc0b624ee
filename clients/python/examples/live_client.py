#!/usr/bin/env python3
"""A live Python client of coopdynd: publishes torque commands and reads the outputs.

    build/bin/coopdynd --scene config/scenes/two_puma_load.yaml &
    python3 live_client.py --add arm1.q2=5 --duration 2

It waits for the daemon's first output_t, takes the torque the daemon applies there (its safe torque
with no command: by default the holding torque) on the DOFs that carry one, adds --add NAME=DELTA
[N*m or N], and publishes that as a torque_command_t (by joint name, seq 1, 2, ...) at --rate Hz
while printing, once a second, the outputs' input (command or not), the applied torque of the first
named joint and the end-effector wrenches. At the end it checks that the daemon applied the commands.

With --key-file (the daemon's auth.key_file: 64 hex digits, mode 0600) each command is signed as
the daemon checks it (docs/guide/service.md "Authenticated inputs"): encoded with mac_len 0, those 4 bytes dropped, an
HMAC-SHA256 under the key of the channel name, a NUL and the remaining bytes, then mac_len 32 and
the MAC appended. Standard library only (hmac, hashlib).

Needs the `lcm` Python module, which Debian 12 does not package: `pip install lcm` (PyPI wheels of
LCM's own bindings) in a virtual environment, or LCM built from source with Python. Without it this
exits with status 77 (what ctest reads as "skipped").
"""
import argparse
import hashlib
import hmac
import os
import stat
import struct
import sys
import time

try:
    import lcm
except ImportError:
    print("live_client.py: the lcm Python module is not installed (Debian 12 has no package for it; "
          "`pip install lcm` in a virtual environment, or build LCM from source with Python); skipping",
          file=sys.stderr)
    sys.exit(77)

try:
    import coopdyn
except ImportError:
    sys.exit("live_client.py: the coopdyn Python package is not on the path: PYTHONPATH=build/python in the build "
             "tree, or PREFIX/lib/python3.X/site-packages after cmake --install (README: Python)")

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"  # coopdynd's default (config/coopdynd.yaml)
MAC_BYTES = 32  # HMAC-SHA256


def read_key_file(path):
    """The 32-byte key of a key file, checked as coopdynd checks it; exits with the reason otherwise."""
    try:
        st = os.stat(path)
        with open(path, "rb") as f:
            text = f.read(80)
    except OSError as e:
        sys.exit("live_client.py: --key-file %s: cannot read the key file: %s" % (path, e.strerror))
    if not stat.S_ISREG(st.st_mode):
        sys.exit("live_client.py: --key-file %s: the key file is not a regular file" % path)
    if st.st_mode & 0o077:
        sys.exit("live_client.py: --key-file %s: the key file is readable or writable by group or others (mode %04o); "
                 "chmod 600 %s" % (path, stat.S_IMODE(st.st_mode), path))
    if text.endswith(b"\n"):
        text = text[:-1]
    if text.endswith(b"\r"):
        text = text[:-1]
    try:
        if len(text) != 2 * MAC_BYTES:
            raise ValueError
        return bytes.fromhex(text.decode("ascii"))
    except ValueError:
        sys.exit("live_client.py: --key-file %s: not a key: expected 64 hex digits (32 bytes) and at most a newline"
                 % path)


def sign(data, channel, key):
    """An encoded message with mac_len 0 (its last 4 bytes), signed for channel: mac_len 32 and the MAC."""
    if data[-4:] != b"\0\0\0\0":
        raise ValueError("sign: the message does not end with mac_len 0")
    body = data[:-4]
    mac = hmac.new(key, channel.encode() + b"\0" + body, hashlib.sha256).digest()
    return body + struct.pack(">i", MAC_BYTES) + mac


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    p.add_argument("--lcm-url", default=DEFAULT_URL, help="LCM URL of the daemon (default: %(default)s)")
    p.add_argument("--command-channel", default="COOPDYN_COMMAND", help="default: %(default)s")
    p.add_argument("--output-channel", default="COOPDYN_OUTPUT", help="default: %(default)s")
    p.add_argument("--add", action="append", default=[], metavar="NAME=DELTA",
                   help="add DELTA (N*m or N) to joint NAME's torque (repeatable)")
    p.add_argument("--rate", type=float, default=100.0, help="commands per second (default: %(default)s)")
    p.add_argument("--duration", type=float, default=2.0, help="seconds to run (default: %(default)s)")
    p.add_argument("--wait", type=float, default=2.0, help="seconds to wait for the daemon's first output "
                                                            "(default: %(default)s)")
    p.add_argument("--key-file", help="sign the commands with the daemon's auth key (auth.key_file)")
    a = p.parse_args()
    key = read_key_file(a.key_file) if a.key_file else None

    lc = lcm.LCM(a.lcm_url)
    latest = []

    def on_output(channel, data):
        latest.append(coopdyn.output_t.decode(data))

    lc.subscribe(a.output_channel, on_output)
    deadline = time.time() + a.wait
    while not latest and time.time() < deadline:
        lc.handle_timeout(100)
    if not latest:
        sys.exit("live_client.py: no output_t on %s at %s within %g s: is coopdynd running (build/bin/coopdynd "
                 "--scene ...) on that URL?" % (a.output_channel, a.lcm_url, a.wait))
    first = latest[-1]
    names = [n for n, t in zip(first.v_names, first.tau) if t != 0.0]
    tau = {n: t for n, t in zip(first.v_names, first.tau) if t != 0.0}
    for item in a.add:
        name, _, delta = item.partition("=")
        if name not in first.v_names:
            sys.exit("live_client.py: --add %s: no joint %r in the daemon's scene (its joints: %s)"
                     % (item, name, ", ".join(first.v_names)))
        if name not in tau:
            names.append(name)
            tau[name] = 0.0
        tau[name] += float(delta)
    if not names:
        sys.exit("live_client.py: the daemon applies no torque and no --add was given: nothing to command")

    seq, sent, applied, outputs = 0, 0, 0, 0
    start = last_print = time.time()
    next_send = start
    while time.time() - start < a.duration:
        now = time.time()
        if now >= next_send:
            seq += 1
            c = coopdyn.torque_command_t()
            c.utime, c.seq = int(now * 1e6), seq
            c.num_names, c.names = len(names), names
            c.num_torques, c.tau = len(names), [tau[n] for n in names]
            c.num_targets, c.target_names, c.target = 0, [], []
            c.mac_len, c.mac = 0, b""
            data = c.encode()
            lc.publish(a.command_channel, sign(data, a.command_channel, key) if key else data)
            sent += 1
            next_send += 1.0 / a.rate
        del latest[:]
        lc.handle_timeout(max(1, int((next_send - time.time()) * 1000)))
        for m in latest:
            outputs += 1
            if m.input == coopdyn.output_t.INPUT_COMMAND and 0 < m.input_seq <= seq:
                # the daemon applied one of ours: its tau on the named joints is what was sent
                got = {n: t for n, t in zip(m.v_names, m.tau)}
                if all(got[n] == tau[n] for n in names):
                    applied += 1
        if latest and time.time() - last_print >= 1.0:
            last_print = time.time()
            m = latest[-1]
            ee = ["%s [%.4g %.4g %.4g %.4g %.4g %.4g]" % (n, w.mx, w.my, w.mz, w.fx, w.fy, w.fz)
                  for n, w, k in zip(m.wrench_names, m.wrench, m.wrench_kind) if k == m.KIND_END_EFFECTOR]
            print("t %.3f s  input %d (seq %d)  %s %.6g  %s" % (m.sim_time, m.input, m.input_seq, names[0],
                                                               dict(zip(m.v_names, m.tau))[names[0]], "  ".join(ee)))
    print("sent %d commands, received %d outputs, %d applied our torques exactly" % (sent, outputs, applied))
    if applied == 0:
        sys.exit("live_client.py: the daemon applied none of the commands (rejected? see its loop_stats_t, "
                 "coopdyn send --help)")


if __name__ == "__main__":
    main()
