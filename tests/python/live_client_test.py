"""The live example (clients/python/examples/live_client.py) against coopdynd over udpm on loopback.

coopdynd runs two_puma_load on a private port (ttl=0); a coopdyn.Client of this test listens to every
output from the first one on (the daemon is ready), then the example runs until it has answered 60
outputs with the holding torque plus a pulse on arm1.q2 in its first 20 commands. Checked against the
daemon's own outputs, as this test received them: every output with the input `command` and one of
the example's seqs applied exactly the torque that command was built from (Scene.holding_torque at
the state of the output the example answered, plus the pulse it printed), both with and without the
pulse; each line the example printed has the wrenches (bit for bit), sim_time and input of the output
of that sim_time; it exits 0. --auth: the daemon runs with auth.key_file; with --key-file the same
holds, without it the example exits 1 (none applied) and the daemon counts its commands
unauthenticated. Every wait is for an event, with a generous bound.
Environment: COOPDYND, COOPDYN_SOURCE_DIR, PYTHONPATH (the coopdyn package), COOPDYN_PYTHON_MODULE.
"""
import os
import re
import subprocess
import sys
import tempfile

SOURCE_DIR = os.environ["COOPDYN_SOURCE_DIR"]
EXAMPLE = os.path.join(SOURCE_DIR, "clients", "python", "examples", "live_client.py")
SCENE = os.path.join(SOURCE_DIR, "config", "scenes", "two_puma_load.yaml")
KEY_HEX = "00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978"
JOINT, PULSE, PULSE_COMMANDS, OUTPUTS = "arm1.q2", 0.5, 20, 60
LINE = re.compile(r"^t (\S+)  input (command #(\d+)|\S+)  sent #(\d+) pulse (\S+)  (.*)$")
WRENCH = re.compile(r"(\S+) \[([^\]]*)\]")


def run_example(url, key_args):
    args = [sys.executable, "-B", EXAMPLE, "--scene", SCENE, "--url", url, "--joint", JOINT, "--pulse", repr(PULSE),
            "--pulse-commands", str(PULSE_COMMANDS), "--outputs", str(OUTPUTS), "--wait", "20"] + key_args
    r = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=50)
    sys.stderr.write(r.stderr)
    return r


def parse(stdout):
    """The example's lines: (sim_time, input, input_seq, sent seq, pulse, {wrench: [6 floats]})."""
    rows = []
    for ln in stdout.splitlines():
        m = LINE.match(ln)
        if m:
            inp = "command" if m.group(3) else m.group(2)
            ws = {n: [float(x) for x in v.split()] for n, v in WRENCH.findall(m.group(6))}
            rows.append((float(m.group(1)), inp, int(m.group(3) or -1), int(m.group(4)), float(m.group(5)), ws))
    return rows


def collect(watch, until_time, seqs):
    """The daemon's outputs by sim_time, read until one past until_time applied none of seqs (or 20 s pass)."""
    outs = {}
    while True:
        o = watch.next_output(timeout=20.0)
        if o is None:
            return outs
        outs[o["sim_time"]] = o
        if o["sim_time"] > until_time and not (o["input"] == "command" and o["input_seq"] in seqs):
            return outs


def check_applied(coopdyn, rows, outs):
    """Failures: commands applied inexactly, printed lines unlike the daemon's outputs; pulse shown applied."""
    scene = coopdyn.load_scene(SCENE)
    j = scene.v_names.index(JOINT)
    expected = {}  # seq -> the torque the example built for it
    errors = []
    for t, inp, in_seq, seq, pulse, ws in rows:
        o = outs.get(t)
        if o is None:
            errors.append("the example printed sim_time %r, which this test never received" % t)
            continue
        if inp != o["input"] or (inp == "command" and in_seq != o["input_seq"]):
            errors.append("t %r: printed input %s #%d, the daemon's %s #%d" % (t, inp, in_seq, o["input"],
                                                                               o["input_seq"]))
        if list(ws) != list(o["wrenches"]) or any(ws[n] != list(o["wrenches"][n]) for n in ws):
            errors.append("t %r: printed wrenches %r differ from the daemon's %r" % (t, ws, o["wrenches"]))
        tau = scene.holding_torque(o["q"], o["v"])
        tau[j] += pulse
        expected[seq] = (tau, pulse)
    applied = [o for o in outs.values() if o["input"] == "command" and o["input_seq"] in expected]
    for o in applied:
        tau, _ = expected[o["input_seq"]]
        if list(o["tau"]) != list(tau):
            errors.append("seq %d: the daemon applied %r, the example sent %r" % (o["input_seq"], o["tau"], tau))
    pulses = {expected[o["input_seq"]][1] for o in applied}
    if pulses != {0.0, PULSE}:
        errors.append("commands applied with the pulses %r, expected both %r and 0" % (sorted(pulses), PULSE))
    return errors, len(applied)


def start_daemon(url, tmp, auth):
    key_args, config_args = [], []
    if auth:
        key = os.path.join(tmp, "coopdyn.key")
        with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(KEY_HEX + "\n")
        config = os.path.join(tmp, "coopdynd.yaml")
        with open(config, "w") as f:
            f.write("auth:\n  key_file: %s\n" % key)
        key_args, config_args = ["--key-file", key], ["--config", config]
    log = open(os.path.join(tmp, "daemon.log"), "w+")
    d = subprocess.Popen([os.environ["COOPDYND"], "--scene", SCENE, "--lcm-url", url, "--rate", "200",
                          "--duration", "60"] + config_args, stdout=log, stderr=subprocess.STDOUT)
    return d, log, key_args


def unsigned_refused(watch, url):
    """Without --key-file: the example exits 1 saying none applied; the daemon counts them unauthenticated."""
    r = run_example(url, [])
    if r.returncode != 1 or "applied none of the commands" not in r.stderr:
        return ["unsigned commands with auth on: the example exited %d" % r.returncode]
    st = watch.next_stats(timeout=20.0)
    while st is not None and st["rejected_by_reason"]["unauthenticated"] < 1:
        st = watch.next_stats(timeout=20.0)
    if st is None:
        return ["the daemon's statistics never counted an unauthenticated command"]
    return []


def main(auth):
    if os.environ.get("COOPDYN_PYTHON_MODULE") != "ON":
        print("SKIPPED: the Python bindings (coopdyn.Client) are not built in this build (COOPDYN_SANITIZE)")
        return 77
    import coopdyn
    url = "udpm://239.255.76.67:%d?ttl=0" % (20000 + (os.getpid() * 13 + (5 if auth else 3)) % 30000)
    with tempfile.TemporaryDirectory() as tmp:
        d, log, key_args = start_daemon(url, tmp, auth)
        try:
            with coopdyn.Client(url) as watch:
                if watch.next_output(timeout=20.0) is None:
                    errors = ["no output from the daemon within 20 s"]
                else:
                    r = run_example(url, key_args)
                    rows = parse(r.stdout)
                    outs = collect(watch, max((row[0] for row in rows), default=0.0), {row[3] for row in rows})
                    errors, n = check_applied(coopdyn, rows, outs)
                    print("%d lines printed, %d outputs received, %d applied the example's commands"
                          % (len(rows), len(outs), n))
                    if r.returncode != 0 or len(rows) != OUTPUTS:
                        errors.append("the example exited %d after %d lines:\n%s" % (r.returncode, len(rows),
                                                                                      r.stdout))
                    if auth and not errors:
                        errors += unsigned_refused(watch, url)
        finally:
            d.terminate()
            d.wait(10)
        log.seek(0)
        for e in errors:
            print("FAILED: " + e)
        if errors:
            print("the daemon's log:\n" + log.read())
        log.close()
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main("--auth" in sys.argv[1:]))
