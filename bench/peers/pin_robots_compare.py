#!/usr/bin/env python3
"""coopdyn against Pinocchio (bench/peers/pin_robots.cc) on one state of a scene of robots holding a load.

  bench/peers/pin_robots_compare.py --peer bench/peers/pin_robots/SCENE.json --pin SCRATCH/pin_robots
      [--coopdyn build/bin/coopdyn] [--state STATE.json | --sim T] [--seed N] [--tau-scale S]
      [--formulation F] [--keep DIR]

The peer file describes the same system for Pinocchio, independently of the scene file (robots by
their URDF and root placement, the load's mass and inertia, the welds by the two frames they join,
wheels as point contacts at v = 0): paths in it are relative to the repository root. The state:
--state FILE.json (coopdyn's q, v, tau in its coordinate order), or the scene's initial state with
v = 0 (default) or the state a `coopdyn sim` reaches at time T (--sim T, v != 0), with torques drawn
uniformly in [-S, S] (seeded; S default 5). Both programs get the state coopdyn eval echoes.

Reported: max |vdot diff| over every coordinate (and relative to max |vdot|), and per weld the max
|wrench diff| relative to the largest component of that wrench; for wheels (v = 0 only: Pinocchio has
no rolling constraint; at v = 0 a rolling wheel's rows are a point contact's) the sum of the ground
forces in world axes (the split between redundant wheels is not unique; each wheel is printed).
Exit 1 when a difference exceeds --tol (default 1e-9, relative).

--strip-mimic (and --neutral-xacro-comments): run on copies, in the temporary folder, of the scene
and its URDFs without their <mimic> elements (and with "xacro:" inside XML comments renamed), the
peer's couplings off: the whole check while coopdyn's tree loader refuses <mimic> (and main's
reader mistakes a commented xacro call for xacro). The shipped files are never changed.

--pin-only: no coopdyn (Pinocchio checked against itself alone): the coordinates are every non-fixed,
non-<mimic> joint of the peer's URDFs and the free-flyers, q from the peer file's "state" (joint
values, free-flyers as [x y z qw qx qy qz]; others 0), v uniform in [-V, V] (--v-scale V, default 0),
random torques; the welds are taken where that state puts the hands, and pin_robots' own check
(constraintDynamics against its KKT) is the result.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def rpy_quat(r, p, y):
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)) as a quaternion w x y z."""
    cr, sr, cp, sp, cy, sy = (math.cos(r / 2), math.sin(r / 2), math.cos(p / 2), math.sin(p / 2),
                              math.cos(y / 2), math.sin(y / 2))
    return [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0,):
        sys.exit("%s failed (%d):\n%s%s" % (" ".join(cmd), p.returncode, p.stdout[-2000:], p.stderr[-4000:]))
    return p.stdout, p.stderr


def coopdyn_state(args, scene, tmp):
    """The state to evaluate: a file, or the initial / simulated state with random torques."""
    if args.state:
        return args.state
    out, _ = run([args.coopdyn, "eval", "--scene", scene] + formulation(args))
    d = json.loads(out)
    q, v = d["q"], [0.0] * len(d["v"])
    if args.sim:
        csv = os.path.join(tmp, "sim.csv")
        run([args.coopdyn, "sim", "--scene", scene, "--duration", str(args.sim), "--dt", "0.001",
             "--out", csv] + formulation(args))
        with open(csv) as f:
            lines = [l.rstrip("\n").split(",") for l in f if l.strip() and not l.startswith("#")]
        col = {h: i for i, h in enumerate(lines[0])}
        last = lines[-1]
        try:
            q = [float(last[col["q:" + n]]) for n in d["coordinates"]["q"]]
            v = [float(last[col["v:" + n]]) for n in d["coordinates"]["v"]]
        except KeyError as e:
            sys.exit("coopdyn sim's CSV has no column %s" % e)
    rng = random.Random(args.seed)
    tau = [rng.uniform(-args.tau_scale, args.tau_scale) for _ in d["v"]]
    path = os.path.join(tmp, "state.json")
    with open(path, "w") as f:
        json.dump({"q": q, "v": v, "tau": tau}, f)
    return path


def formulation(args):
    return ["--formulation", args.formulation] if args.formulation else []


def workaround_copies(peer, args, tmp):
    """--strip-mimic / --neutral-xacro-comments: the scene and URDFs copied into tmp, edited."""
    import re
    scene_text = open(os.path.join(REPO, peer["scene"])).read()
    for r in peer["robots"]:
        src = os.path.join(REPO, r["urdf"])
        text = open(src).read()
        if args.strip_mimic:
            text = re.sub(r"[ \t]*<mimic\b[^>]*/>[ \t]*\n", "", text)
        if args.neutral_xacro_comments:
            text = re.sub(r"<!--.*?-->", lambda m: m.group(0).replace("xacro:", "xacro_"), text, flags=re.S)
        dst = os.path.join(tmp, os.path.basename(src))
        with open(dst, "w") as f:
            f.write(text)
        scene_text = scene_text.replace("../robots/" + os.path.basename(src), dst)
        r["urdf"] = dst
    scene = os.path.join(tmp, os.path.basename(peer["scene"]))
    with open(scene, "w") as f:
        f.write(scene_text)
    if args.strip_mimic:
        peer["nomimic"] = True
    return scene


def problem_text(peer, d):
    """The pin_robots problem file for the state coopdyn evaluated (d: coopdyn eval's JSON)."""
    L = ["gravity %r %r %r" % tuple(peer.get("gravity", [0, 0, -9.81]))]
    for r in peer["robots"]:
        quat = rpy_quat(*r.get("rpy", [0, 0, 0]))
        L.append("robot %s %s %s %s" % (r["prefix"], os.path.join(REPO, r["urdf"]), r.get("root", "fixed"),
                                         " ".join(repr(x) for x in list(r.get("xyz", [0, 0, 0])) + quat)))
    for b in peer.get("bodies", []):
        L.append("body %s %r %s %s" % (b["name"], b["mass"], " ".join(map(repr, b.get("com", [0, 0, 0]))),
                                       " ".join(map(repr, b["inertia"]))))
    for w in peer.get("welds", []):
        where = w.get("placement", "at_state")
        if where != "at_state":
            where = " ".join(map(repr, list(where["xyz"]) + rpy_quat(*where.get("rpy", [0, 0, 0]))))
        L.append("weld %s %s %s %s" % (w["name"], w["frame"], w["body"], where))
    for p in peer.get("points", []):
        L.append("point %s %s %r" % (p["name"], p["frame"], p["radius"]))
    if peer.get("nomimic"):
        L.append("nomimic")
    for key, names in (("q", d["coordinates"]["q"]), ("v", d["coordinates"]["v"]), ("tau", d["coordinates"]["v"])):
        L.append("%s %d %s" % (key, len(names), " ".join("%s %r" % (n, x) for n, x in zip(names, d[key]))))
    return "\n".join(L) + "\n"


def pin_only_state(peer, args):
    """coopdyn-like eval output for --pin-only: every non-fixed, non-mimic URDF joint a coordinate."""
    given = peer.get("state", {})
    qn, vn, q = [], [], []
    ff_q = ("x", "y", "z", "qw", "qx", "qy", "qz")
    ff_v = ("wx", "wy", "wz", "vx", "vy", "vz")
    for r in peer["robots"]:
        if r.get("root") == "floating":
            qn += [r["prefix"] + "." + c for c in ff_q]
            q += given.get(r["prefix"], [0, 0, 0, 1, 0, 0, 0])
            vn += [r["prefix"] + "." + c for c in ff_v]
        for j in ET.parse(os.path.join(REPO, r["urdf"])).getroot().findall("joint"):
            if j.get("type") in ("fixed", "floating", "planar") or j.find("mimic") is not None:
                continue
            n = r["prefix"] + "." + j.get("name")
            qn.append(n)
            vn.append(n)
            q.append(given.get(n, 0.0))
    for b in peer.get("bodies", []):
        qn += [b["name"] + "." + c for c in ff_q]
        q += given[b["name"]]
        vn += [b["name"] + "." + c for c in ff_v]
    rng = random.Random(args.seed)
    v = [rng.uniform(-args.v_scale, args.v_scale) for _ in vn]
    tau = [rng.uniform(-args.tau_scale, args.tau_scale) for _ in vn]
    for w in peer.get("welds", []):
        w["placement"] = "at_state"
    return {"coordinates": {"q": qn, "v": vn}, "q": q, "v": v, "tau": tau}


def parse_pin(out):
    vdot, wrench, frame, checks = {}, {}, {}, []
    for line in out.splitlines():
        f = line.split()
        if not f:
            continue
        if f[0] == "vdot":
            vdot[f[1]] = float(f[2])
        elif f[0] == "wrench":
            wrench[f[1]] = [float(x) for x in f[2:8]]
        elif f[0] == "frame":
            frame[f[1]] = [float(x) for x in f[2:14]]
        elif f[0] == "check":
            checks.append(line)
    return vdot, wrench, frame, checks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--peer", required=True)
    ap.add_argument("--pin", required=True, help="the pin_robots program (pin_robots_build.sh)")
    ap.add_argument("--coopdyn", default=os.path.join(REPO, "build", "bin", "coopdyn"))
    ap.add_argument("--state")
    ap.add_argument("--sim", type=float)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--tau-scale", type=float, default=5.0)
    ap.add_argument("--formulation")
    ap.add_argument("--tol", type=float, default=1e-9)
    ap.add_argument("--keep", help="write the state, coopdyn's JSON and the problem file here")
    ap.add_argument("--pin-only", action="store_true", help="no coopdyn: Pinocchio's own check only")
    ap.add_argument("--strip-mimic", action="store_true", help="copies without <mimic>, couplings off")
    ap.add_argument("--neutral-xacro-comments", action="store_true", help="copies with xacro: renamed in comments")
    ap.add_argument("--v-scale", type=float, default=0.0, help="--pin-only: v uniform in [-V, V]")
    args = ap.parse_args()
    with open(args.peer) as f:
        peer = json.load(f)
    scene = os.path.join(REPO, peer["scene"])
    tmp = args.keep or tempfile.mkdtemp(prefix="pin_robots_")
    os.makedirs(tmp, exist_ok=True)
    if args.strip_mimic or args.neutral_xacro_comments:
        scene = workaround_copies(peer, args, tmp)
    if args.pin_only:
        if peer.get("points") and args.v_scale:
            sys.exit("point contacts stand for wheels at v = 0 only: --v-scale 0")
        prob = os.path.join(tmp, "problem.txt")
        with open(prob, "w") as f:
            f.write(problem_text(peer, pin_only_state(peer, args)))
        pout, _ = run([args.pin, prob])
        checks = parse_pin(pout)[3]
        print("%s, Pinocchio only (v uniform in +-%g, torques in +-%g):" % (peer["scene"], args.v_scale, args.tau_scale))
        for c in checks:
            print("  " + c[6:])
        return 0
    state = coopdyn_state(args, scene, tmp)
    out, err = run([args.coopdyn, "eval", "--scene", scene, "--state", state] + formulation(args))
    d = json.loads(out)
    if peer.get("points") and any(abs(x) > 0 for x in d["v"]):
        sys.exit("wheels are compared at v = 0 only (Pinocchio has no rolling constraint)")
    prob = os.path.join(tmp, "problem.txt")
    with open(prob, "w") as f:
        f.write(problem_text(peer, d))
    with open(os.path.join(tmp, "coopdyn_eval.json"), "w") as f:
        f.write(out)
    pout, _ = run([args.pin, prob])
    vdot, wrench, frame, checks = parse_pin(pout)

    names = d["coordinates"]["v"]
    dv = max(abs(d["vdot"][i] - vdot[n]) for i, n in enumerate(names))
    vmax = max(abs(x) for x in d["vdot"])
    print("%s (%s, %s): %d coordinates, |v| max %.3g, |tau| max %.3g" % (
        peer["scene"], d["formulation"], "state " + (args.state or ("sim %g s" % args.sim if args.sim else "initial, v = 0")),
        len(names), max(abs(x) for x in d["v"]), max(abs(x) for x in d["tau"])))
    for c in checks:
        print("  pinocchio " + c[6:])
    print("  vdot: max |diff| %.3e, max |vdot| %.3e, relative %.3e" % (dv, vmax, dv / vmax))
    worst = dv / vmax
    by_name = {w["name"]: w for w in d["wrenches"]}
    for w in peer.get("welds", []):
        c = by_name.get(w["name"])
        if c is None:
            sys.exit("coopdyn reports no wrench named %s (its wrenches: %s)" % (w["name"], ", ".join(by_name)))
        mine = c["moment"] + c["force"]
        diff = max(abs(a - b) for a, b in zip(mine, wrench[w["name"]]))
        scale = max(abs(x) for x in mine)
        fr = frame[w["name"]]
        dpos = max(abs(a - b) for a, b in zip(c["frame_W"]["p"], fr[:3]))
        drot = max(abs(c["frame_W"]["R"][i][j] - fr[3 + 3 * i + j]) for i in range(3) for j in range(3))
        print("  wrench %s: max |diff| %.3e, max component %.3e, relative %.3e; frame A: |dp| %.1e, |dR| %.1e"
              % (w["name"], diff, scale, diff / scale, dpos, drot))
        worst = max(worst, diff / scale)
    if peer.get("points"):
        total_c, total_p = [0.0] * 3, [0.0] * 3
        for p in peer["points"]:
            c = by_name[p["name"]]
            R = c["frame_W"]["R"]
            fW = [sum(R[i][j] * c["force"][j] for j in range(3)) for i in range(3)]
            fp = wrench[p["name"]][3:]
            print("  wheel %s: ground force (world) coopdyn [%.6g %.6g %.6g], pinocchio [%.6g %.6g %.6g]"
                  % ((p["name"],) + tuple(fW) + tuple(fp)))
            total_c = [a + b for a, b in zip(total_c, fW)]
            total_p = [a + b for a, b in zip(total_p, fp)]
        diff = max(abs(a - b) for a, b in zip(total_c, total_p))
        scale = max(abs(x) for x in total_c)
        print("  wheels' total ground force: max |diff| %.3e of %.3e, relative %.3e" % (diff, scale, diff / scale))
        worst = max(worst, diff / scale)
    print("  worst relative difference %.3e (tolerance %.0e): %s" % (worst, args.tol, "ok" if worst <= args.tol else "FAIL"))
    return 0 if worst <= args.tol else 1


if __name__ == "__main__":
    sys.exit(main())
