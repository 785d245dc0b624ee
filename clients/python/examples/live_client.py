#!/usr/bin/env python3
"""A small controller of coopdynd in Python: holds the robots, pulses one joint, prints the wrenches.

    build/bin/coopdynd --scene config/scenes/two_puma_load.yaml &
    PYTHONPATH=build/python python3 live_client.py --scene config/scenes/two_puma_load.yaml --outputs 200

For every output_t of the daemon it receives (coopdyn.Client: liblcm and the service's own codec, no
Python LCM package), it answers with a torque_command_t over all of the scene's joints: the holding
torque at the output's state (Scene.holding_torque(q, v), the daemon's safe torque `hold`), plus
--pulse (N*m or N) on --joint in its first --pulse-commands commands. It always answers the newest
output (older ones queued meanwhile are skipped). The scene must be the daemon's (its joints are
checked against the outputs' names).

One line per output answered: sim_time (s), the input the daemon applied (`command #SEQ` for ours), the seq of
the command sent in answer and the pulse it carries, and every wrench [mx my mz fx fy fz] (N*m, N, in
the frame of `coopdyn eval`'s wrenches) with floats printed so that they read back to the same doubles.
It stops after --outputs outputs or --duration s (whichever first), prints a summary and exits 0 if
the daemon applied at least one of its commands, 1 otherwise (refused: see the daemon's loop_stats_t).
With --key-file (the daemon's auth.key_file) every command is signed as the daemon checks it.
"""
import argparse
import sys
import time

try:
    import numpy  # noqa: F401 (the bindings' arrays)
except ImportError:
    sys.exit("live_client.py: numpy is not installed for %s (Debian: python3-numpy; the bindings are built for "
             "/usr/bin/python3)" % sys.executable)
try:
    import coopdyn
    coopdyn.Client
except (ImportError, AttributeError):
    sys.exit("live_client.py: the coopdyn Python package with its compiled bindings is not on the path: "
             "PYTHONPATH=build/python in the build tree, or pip install ./clients/python (docs/guide/python.md)")

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"  # coopdynd's default (config/coopdynd.yaml)


def fmt(x):
    return repr(float(x))  # the shortest text that reads back to the same double


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    p.add_argument("--scene", required=True, help="the daemon's scene file (YAML)")
    p.add_argument("--url", default=DEFAULT_URL, help="LCM URL of the daemon (default: %(default)s)")
    p.add_argument("--joint", default=None, help="the joint to pulse (default: the scene's first actuated one)")
    p.add_argument("--pulse", type=float, default=0.5, help="N*m or N added to --joint (default: %(default)s)")
    p.add_argument("--pulse-commands", type=int, default=20,
                   help="how many commands (the first ones) carry the pulse (default: %(default)s)")
    p.add_argument("--outputs", type=int, default=0, help="stop after this many outputs (0: no limit)")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0: no limit)")
    p.add_argument("--wait", type=float, default=5.0, help="s to wait for each output (default: %(default)s)")
    p.add_argument("--key-file", default=None, help="sign the commands with the daemon's auth key (auth.key_file)")
    a = p.parse_args()
    if a.outputs <= 0 and a.duration <= 0:
        p.error("give --outputs N or --duration S (when to stop)")
    return a


def pulse_index(scene, joint):
    """Index in v_names of the joint to pulse: a named actuated joint, or the first actuated one."""
    limits = scene.tau_limit
    if joint is None:
        actuated = [i for i, lim in enumerate(limits) if lim > 0]
        if not actuated:
            sys.exit("live_client.py: the scene has no actuated joint to pulse")
        return actuated[0]
    if joint not in scene.v_names:
        sys.exit("live_client.py: --joint %s: no such joint in the scene (its joints: %s)"
                 % (joint, ", ".join(scene.v_names)))
    i = scene.v_names.index(joint)
    if limits[i] <= 0:
        sys.exit("live_client.py: --joint %s: the joint is not actuated (tau_limit 0)" % joint)
    return i


def line(o, seq, pulse):
    ws = "  ".join("%s [%s]" % (n, " ".join(fmt(x) for x in w)) for n, w in o["wrenches"].items())
    inp = "command #%d" % o["input_seq"] if o["input"] == "command" else o["input"]
    return "t %s  input %s  sent #%d pulse %s  %s" % (fmt(o["sim_time"]), inp, seq, fmt(pulse), ws)


def run(a, scene, c):
    j = pulse_index(scene, a.joint)
    first = c.next_output(timeout=a.wait, latest=True)
    if first is None:
        sys.exit("live_client.py: no output_t at %s within %g s: is coopdynd running (build/bin/coopdynd --scene "
                 "...) on that URL?" % (a.url, a.wait))
    if list(first["v_names"]) != scene.v_names:
        sys.exit("live_client.py: --scene %s is not the daemon's scene: its joints %s, the daemon's %s"
                 % (a.scene, scene.v_names, list(first["v_names"])))
    start, o = time.monotonic(), first
    sent, received, applied, ours = 0, 0, 0, set()
    while True:
        received += 1
        if o["input"] == "command" and o["input_seq"] in ours:
            applied += 1
        pulse = a.pulse if sent < a.pulse_commands else 0.0
        tau = scene.holding_torque(o["q"], o["v"])
        tau[j] += pulse
        seq = c.publish_torque(tau, names=scene.v_names)
        ours.add(seq)
        sent += 1
        print(line(o, seq, pulse), flush=True)
        if (a.outputs > 0 and received >= a.outputs) or (a.duration > 0 and time.monotonic() - start >= a.duration):
            break
        o = c.next_output(timeout=a.wait, latest=True)
        if o is None:
            sys.exit("live_client.py: the daemon's outputs stopped (none within %g s)" % a.wait)
    print("%d outputs answered, %d commands sent (pulse %s on %s), %d outputs applied ours"
          % (received, sent, fmt(a.pulse), scene.v_names[j], applied))
    return applied


def main():
    a = parse_args()
    try:
        scene = coopdyn.load_scene(a.scene)
        c = coopdyn.Client(a.url, key_file=a.key_file)
    except ValueError as e:  # a broken scene (file:line:col: reason) or key file
        sys.exit("live_client.py: %s" % e)
    with c:
        applied = run(a, scene, c)
    if applied == 0:
        sys.exit("live_client.py: the daemon applied none of the commands (refused? see its loop_stats_t: "
                 "coopdyn spy)")


if __name__ == "__main__":
    main()
