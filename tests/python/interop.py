"""Shared by the Python tests: the C++ helper (lcm_interop_helper) and exact comparisons.

The helper writes every double as a C99 hex float ("%a"); float.fromhex reads it back bit for bit.
Environment (set by ctest): COOPDYN_INTEROP_HELPER, COOPDYN_SOURCE_DIR, PYTHONPATH (the coopdyn package).
"""
import json
import os
import struct
import subprocess

HELPER = os.environ.get("COOPDYN_INTEROP_HELPER", "")
SOURCE_DIR = os.environ.get("COOPDYN_SOURCE_DIR", "")


def scene_path(name):
    return os.path.join(SOURCE_DIR, "config", "scenes", name + ".yaml")


def helper(*args):
    """Runs the helper; returns its stdout parsed as JSON (None if it printed nothing)."""
    r = subprocess.run([HELPER] + [str(a) for a in args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    if r.returncode != 0:
        raise AssertionError("lcm_interop_helper %s failed (%d): %s" % (" ".join(map(str, args)), r.returncode,
                                                                        r.stderr))
    return json.loads(r.stdout) if r.stdout.strip() else None


def bits(x):
    return struct.pack(">d", x)


def same(test, py, cpp, where):
    """py (decoded or encoded by Python) equals cpp (the helper's JSON) exactly: doubles bit for bit
    (hex strings in cpp), integers and strings by value, lists element by element."""
    if hasattr(py, "mx"):  # a wrench_t: its named fields in the order of the C++ [6] array
        py = [py.mx, py.my, py.mz, py.fx, py.fy, py.fz]
    if isinstance(cpp, list):
        test.assertIsInstance(py, (list, tuple), where)
        test.assertEqual(len(py), len(cpp), where + ": length")
        for i, (a, b) in enumerate(zip(py, cpp)):
            same(test, a, b, "%s[%d]" % (where, i))
    elif isinstance(py, float):
        test.assertIsInstance(cpp, str, where)
        test.assertEqual(bits(py), bits(float.fromhex(cpp)), "%s: %r vs %s" % (where, py, cpp))
    else:
        test.assertEqual(py, cpp, where)


def scene_info(name):
    """The scene's names, limits and initial state, as the C++ loader has them."""
    s = helper("scene", scene_path(name))
    for k in ("tau_limit", "q0", "v0"):
        s[k] = [float.fromhex(x) for x in s[k]]
    return s
