# coopdyn.study: the same numbers serially and on 2 Dask workers (byte for byte), a worker SIGKILLed
# mid-study loses no sample and repeats none, --resume after SIGINT gives the uninterrupted file, the
# payload at a pose is where a direct holding torque reaches a limit, and bad specs are refused by line.
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from conftest import SOURCE

pytest.importorskip("distributed")
from coopdyn import study  # noqa: E402
from coopdyn.study import compute, scenes  # noqa: E402

SCENE = str(SOURCE / "config" / "scenes" / "two_puma_load.yaml")

# hold kind, grid x seeded draws (mass, mass error), 6 chunks of 4
MONTE_CARLO = f"""
scene: {SCENE}
kind: hold
seed: 7
draws: 8
chunk: 4
variables:
  load.x: {{grid: [-0.1, 0.1, 3]}}
  load.mass: {{uniform: [2.0, 12.0]}}
  load.mass_error: {{normal: [0.0, 0.05]}}
"""


def rows(path):
    with open(path) as f:
        return [ln for ln in f if not ln.startswith("#")][1:]


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "mc.csv"
    study(MONTE_CARLO, out=str(out), workers=0)
    return out


def test_serial_file(serial):
    r = rows(serial)
    assert [int(x.split(",")[0]) for x in r] == list(range(24))
    text = serial.read_text()
    assert "# commit: " in text and "# |   load.mass: {uniform: [2.0, 12.0]}" in text


def test_two_workers_equal_serial(serial, tmp_path):
    out = tmp_path / "mc2.csv"
    study(MONTE_CARLO, out=str(out), workers=2)
    assert out.read_bytes() == serial.read_bytes()


def test_worker_killed_mid_study(serial, tmp_path):
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.wait_for_workers(2)
        pids = client.run(os.getpid)
        killed = []

        def on_chunk(k):  # after the first chunk is written, while the others are queued or running
            if not killed:
                assert k < 5
                victim = sorted(pids.values())[0]
                os.kill(victim, signal.SIGKILL)
                killed.append(victim)

        out = tmp_path / "killed.csv"
        study(MONTE_CARLO, out=str(out), client=client, on_chunk=on_chunk)
    assert killed
    assert out.read_bytes() == serial.read_bytes()  # complete, in order, each sample once


def test_resume_after_sigint(serial, tmp_path):
    out = tmp_path / "resumed.csv"

    def interrupt(k):
        if k == 2:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        study(MONTE_CARLO, out=str(out), workers=0, on_chunk=interrupt)
        for _ in range(10**6):  # the signal is handled between bytecodes: never reached in practice
            pass
    assert 0 < len(rows(out)) < 24 and len(rows(out)) % 4 == 0
    with open(out, "a") as f:
        f.write("12,0.1,3.5")  # a chunk cut mid-row, as a crash leaves it
    study(MONTE_CARLO, out=str(out), workers=0, resume=True)
    assert out.read_bytes() == serial.read_bytes()


def test_payload_is_where_holding_torque_reaches_a_limit():
    spec = f"scene: {SCENE}\nkind: payload\nvariables:\n  load.x: {{values: [0.1]}}\n  load.z: {{values: [-0.15]}}\n"
    s = study.load(spec)
    cols = compute.columns(s)
    (row,) = study(spec, workers=0)
    r = dict(zip(cols, row))
    m = r["payload"]
    assert r["status"] == "ok" and 1.0 < m < 1000.0
    q, err = scenes.load_moved(s.scene, np.array([0.1, 0.0, -0.15]))
    assert err < 1e-9
    direct = scenes.scene(s.scene_path, m)  # the scene re-loaded with the box at the payload mass
    tau = direct.holding_torque(q, clamp=False)
    act = [i for i, L in enumerate(direct.tau_limit) if L > 0]
    limit = np.asarray(direct.tau_limit)[act]
    for j, i in enumerate(act):
        assert r[f"tau.{direct.v_names[i]}"] == pytest.approx(tau[i], rel=1e-9, abs=1e-9)
    util = np.abs(tau[act]) / limit
    assert direct.v_names[act[int(np.argmax(util))]] == r["binding"]
    assert np.max(util) == pytest.approx(1.0, abs=1e-9)
    # 1 % heavier is past a limit; 1 % lighter is within all
    heavier = scenes.scene(s.scene_path, 1.01 * m).holding_torque(q, clamp=False)
    lighter = scenes.scene(s.scene_path, 0.99 * m).holding_torque(q, clamp=False)
    assert np.max(np.abs(heavier[act]) / limit) > 1.0 > np.max(np.abs(lighter[act]) / limit)
    # the hands carry the box: their vertical forces (world axes) sum to m g plus nothing else of the load
    hands = compute.hand_names(direct)
    ev = direct.evaluate(q, None, tau)
    fz = sum((direct.frame_pose(h, q)[:3, :3] @ ev.wrenches[h][3:])[2] for h in hands)
    assert abs(fz) == pytest.approx(m * 9.81, rel=1e-6)


@pytest.mark.parametrize("body,line,key", [
    ("kind: payload\nvariables:\n  load.w: {grid: [0, 1, 3]}\n", 5, "variables.load.w: unknown variable"),
    ("kind: payload\nvariables:\n  load.x: {grid: [0, 1, 0]}\n", 5, "variables.load.x.grid"),
    ("kind: hold\nvariables:\n  load.mass: {uniform: [3, 3]}\ndraws: 4\n", 5, "variables.load.mass.uniform"),
    ("kind: hold\nvariables:\n  load.mass: {values: []}\n", 5, "range has no sample"),
    ("kind: payloads\n", 3, "kind"),
])
def test_bad_spec_refused_by_line(tmp_path, body, line, key):
    f = tmp_path / "bad.yaml"
    f.write_text(f"scene: {SCENE}\n# a study\n{body}")
    p = subprocess.run([sys.executable, "-m", "coopdyn.study", str(f), "--out", str(tmp_path / "o.csv"),
                        "--workers", "0"], capture_output=True, text=True)
    assert p.returncode == 2
    assert f"{f}:{line}: " in p.stderr and key in p.stderr, p.stderr
    assert not (tmp_path / "o.csv").exists()  # nothing started


def test_broken_scene_refused(tmp_path):
    scene = tmp_path / "broken.yaml"
    scene.write_text("name: broken\ngravity: [0, 0]\n")
    f = tmp_path / "s.yaml"
    f.write_text(f"kind: hold\nscene: {scene}\n")
    with pytest.raises(study.StudyError, match=rf"{f}:2: scene: the scene does not load: .*broken.yaml:2"):
        study(str(f), out=str(tmp_path / "o.csv"), workers=0)
    assert not (tmp_path / "o.csv").exists()
