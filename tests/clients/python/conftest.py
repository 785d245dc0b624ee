# Shared by the tests of the Python bindings (coopdyn._core): where the sources and programs are
# (COOPDYN_SOURCE_DIR, COOPDYN, COOPDYND, set by ctest), and runners of the command line to compare with.
import json
import os
import subprocess
from pathlib import Path

import pytest

SOURCE = Path(os.environ.get("COOPDYN_SOURCE_DIR", Path(__file__).resolve().parents[3]))
SCENES = sorted((SOURCE / "config" / "scenes").glob("*.yaml"))
COOPDYN = os.environ.get("COOPDYN", "coopdyn")


def run_cli(*args, **kw):
    """coopdyn ARGS: (returncode, stdout, stderr)."""
    p = subprocess.run([COOPDYN, *map(str, args)], capture_output=True, text=True, **kw)
    return p.returncode, p.stdout, p.stderr


def cli_eval(scene, state=None, tmp_path=None, hold=False):
    """coopdyn eval's JSON object for the scene at the state (dict with q, v, tau lists)."""
    args = ["eval", "--scene", scene]
    if state is not None:
        f = tmp_path / "state.json"
        f.write_text(json.dumps({k: [float(x) for x in v] for k, v in state.items()}))
        args += ["--state", f]
    if hold:
        args.append("--hold")
    rc, out, err = run_cli(*args)
    assert rc in (0, 3), err
    return json.loads(out, parse_int=float)  # -0 keeps its sign


@pytest.fixture(scope="session")
def coopdyn_module():
    import coopdyn
    return coopdyn
