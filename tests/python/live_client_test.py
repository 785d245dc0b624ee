"""The live example (clients/python/examples/live_client.py) against coopdynd over udpm on loopback.

Without the lcm Python module (Debian 12 has none) the example says so and exits 77, which ctest
reports as skipped (SKIP_RETURN_CODE). With it: coopdynd on a private port (ttl=0), the example
publishes torque commands for 1 s and checks that the daemon applied them exactly; its summary line
is checked here. --auth: the daemon runs with auth.key_file; the example signs with --key-file and its
commands are applied, then runs without it and none is (the daemon counts them unauthenticated).
Environment: COOPDYND (the daemon), COOPDYN_SOURCE_DIR, PYTHONPATH (the coopdyn package).
"""
import os
import re
import subprocess
import sys
import tempfile

SOURCE_DIR = os.environ["COOPDYN_SOURCE_DIR"]
EXAMPLE = os.path.join(SOURCE_DIR, "clients", "python", "examples", "live_client.py")


KEY_HEX = "00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978"


def run_example(url, env, extra):
    r = subprocess.run([sys.executable, "-B", EXAMPLE, "--lcm-url", url, "--add", "arm1.q2=2.5", "--duration", "1",
                        "--wait", "20"] + extra,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=30, env=env)
    sys.stdout.write(r.stdout)
    sys.stderr.write(r.stderr)
    return r


def main(stand_in, auth):
    env = dict(os.environ)
    if stand_in:
        env["PYTHONPATH"] = os.path.join(os.path.dirname(os.path.abspath(__file__)), "udpm") + os.pathsep + \
            env.get("PYTHONPATH", "")
    try:
        if not stand_in:
            import lcm  # noqa: F401
    except ImportError:
        # the example's own check, message and status
        r = subprocess.run([sys.executable, "-B", EXAMPLE], stderr=subprocess.PIPE, universal_newlines=True)
        sys.stderr.write(r.stderr)
        if r.returncode != 77 or "lcm Python module is not installed" not in r.stderr:
            print("FAILED: without the lcm module the example should exit 77 saying so, got %d" % r.returncode)
            return 1
        print("SKIPPED: the lcm Python module is not installed (pip install lcm; Debian 12 has none)")
        return 77
    url = "udpm://239.255.76.67:%d?ttl=0" % (20000 + (os.getpid() * 13) % 30000)
    scene = os.path.join(SOURCE_DIR, "config", "scenes", "two_puma_load.yaml")
    daemon_log = tempfile.TemporaryFile(mode="w+")
    tmp = tempfile.TemporaryDirectory()
    key_args, config_args = [], []
    if auth:
        key = os.path.join(tmp.name, "coopdyn.key")
        with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(KEY_HEX + "\n")
        config = os.path.join(tmp.name, "coopdynd.yaml")
        with open(config, "w") as f:
            f.write("auth:\n  key_file: %s\n" % key)
        key_args, config_args = ["--key-file", key], ["--config", config]
    daemon = subprocess.Popen([os.environ["COOPDYND"], "--scene", scene, "--lcm-url", url, "--rate", "500",
                               "--duration", "30"] + config_args, stdout=daemon_log, stderr=subprocess.STDOUT)
    try:
        r = run_example(url, env, key_args)
        unsigned = run_example(url, env, []) if auth else None
    finally:
        daemon.terminate()
        daemon.wait(10)
    daemon_log.seek(0)
    log = daemon_log.read()
    if unsigned is not None:
        # none applied: the example says so and exits non-zero; the daemon counted them unauthenticated
        if unsigned.returncode == 0 or "applied none of the commands" not in unsigned.stderr or \
                "unauthenticated (no MAC)" not in log:
            print("FAILED: unsigned commands with auth on: exit %d; the daemon's log:\n%s" % (unsigned.returncode, log))
            return 1
    m = re.search(r"sent (\d+) commands, received (\d+) outputs, (\d+) applied our torques exactly", r.stdout)
    if r.returncode != 0 or not m:
        print("FAILED: the example exited %d; the daemon's log:\n%s" % (r.returncode, log))
        return 1
    sent, outputs, applied = map(int, m.groups())
    # 100 commands/s for 1 s; the daemon at 500 Hz applies each from the tick after it arrives
    if not (sent >= 50 and outputs >= 250 and applied >= outputs // 2):
        print("FAILED: sent %d, outputs %d, applied %d" % (sent, outputs, applied))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main("--udpm-stand-in" in sys.argv[1:], "--auth" in sys.argv[1:]))
