"""A study file: its YAML, checked whole before any work starts.

A study names a scene, the variables drawn or swept per sample, and what each sample reports
(docs/guide/studies.md). Every refusal is a StudyError 'FILE:LINE: key: reason'.
"""
import hashlib
import math
import os

import yaml

KINDS = ("hold", "payload", "evaluate")
LOAD_OFFSETS = ("load.x", "load.y", "load.z")   # m, the load's position offset from the scene's pose
ERRORS = ("load.mass_error",)                    # relative error of the model's load mass (1 = 100 %)
SAMPLERS = ("grid", "values", "uniform", "normal")
TOP_KEYS = ("scene", "kind", "seed", "draws", "chunk", "variables", "description", "name")


class StudyError(ValueError):
    """A study file that cannot run: the message names the file, line and key."""


class _Loader(yaml.SafeLoader):
    pass


def _mapping_with_lines(loader, node):
    d = loader.construct_mapping(node, deep=True)
    lines = {}
    for k, v in node.value:
        lines[loader.construct_object(k)] = k.start_mark.line + 1
    return _Lined(d, lines, node.start_mark.line + 1)


class _Lined(dict):
    def __init__(self, d, lines, line):
        super().__init__(d)
        self.lines, self.line = lines, line


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping_with_lines)


class Variable:
    """One variable: a grid (start, stop, count), listed values, or a seeded draw."""

    def __init__(self, name, sampler, args):
        self.name, self.sampler, self.args = name, sampler, args

    @property
    def random(self):
        return self.sampler in ("uniform", "normal")

    def grid_values(self):
        if self.sampler == "values":
            return [float(x) for x in self.args]
        a, b, n = self.args
        n = int(n)
        return [a + (b - a) * i / (n - 1) for i in range(n)] if n > 1 else [float(a)]


class Spec:
    """A checked study: scene path and text, kind, variables (grids first, in file order), seed, draws."""

    def __init__(self, path, text, data):
        self.path, self.text, self.data = path, text, data
        self.digest = hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def grids(self):
        return [v for v in self.variables if not v.random]

    @property
    def draws_vars(self):
        return [v for v in self.variables if v.random]

    @property
    def grid_shape(self):
        return [len(v.grid_values()) for v in self.grids]

    @property
    def count(self):
        return math.prod(self.grid_shape) * self.draws


def _fail(where, line, key, reason):
    raise StudyError(f"{where}:{line}: {key}: {reason}")


def _number(where, line, key, x):
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        _fail(where, line, key, f"not a finite number: {x!r}")
    return float(x)


def _variable(where, name, body, line, scene_q, scene_v):
    known = LOAD_OFFSETS + ("load.mass",) + ERRORS
    if name not in known and name not in scene_q and not (name.startswith("tau.") and name[4:] in scene_v):
        _fail(where, line, f"variables.{name}", "unknown variable (known: " + ", ".join(known) +
              ", a joint of the scene: " + ", ".join(scene_q) +
              ", or tau.<joint> for kind evaluate)")
    if not isinstance(body, dict) or len(body) != 1:
        _fail(where, line, f"variables.{name}", "one of {grid: [start, stop, count]}, {values: [...]}, "
              "{uniform: [low, high]}, {normal: [mean, sd]}")
    (sampler, args), = body.items()
    key = f"variables.{name}.{sampler}"
    if sampler not in SAMPLERS:
        _fail(where, line, key, "unknown sampler (grid, values, uniform, normal)")
    if not isinstance(args, list):
        _fail(where, line, key, "a list")
    args = [_number(where, line, key, x) for x in args]
    if sampler == "values" and not args:
        _fail(where, line, key, "no value: the range has no sample")
    if sampler == "grid":
        if len(args) != 3 or args[2] != int(args[2]) or args[2] < 1:
            _fail(where, line, key, "[start, stop, count] with count a whole number >= 1: the range has no sample"
                  if len(args) == 3 else "[start, stop, count]")
        if args[2] == 1 and args[0] != args[1]:
            _fail(where, line, key, "count 1 with start != stop: which one is meant")
    if sampler in ("uniform", "normal") and len(args) != 2:
        _fail(where, line, key, "[low, high]" if sampler == "uniform" else "[mean, sd]")
    if sampler == "uniform" and not args[0] < args[1]:
        _fail(where, line, key, "low < high needed: the range has no sample")
    if sampler == "normal" and not args[1] >= 0:
        _fail(where, line, key, "sd >= 0 needed")
    return Variable(name, sampler, args)


def load(source, base=None, where=None):
    """A Spec from a file path, or from YAML text (relative scene paths then from `base`, default the
    working directory; `where` names it in messages)."""
    if "\n" not in source and os.path.exists(source):
        where, base = source, os.path.dirname(os.path.abspath(source))
        with open(source) as f:
            text = f.read()
    else:
        where, base, text = where or "<string>", base or os.getcwd(), source
    try:
        data = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        raise StudyError(f"{where}:{mark.line + 1 if mark else 1}: not YAML: {getattr(e, 'problem', e)}") from None
    if not isinstance(data, _Lined):
        raise StudyError(f"{where}:1: a study is a mapping (scene:, variables:, ...)")
    line = data.lines.get
    for k in data:
        if k not in TOP_KEYS:
            _fail(where, line(k), k, "unknown key (known: " + ", ".join(TOP_KEYS) + ")")
    if "scene" not in data:
        _fail(where, 1, "scene", "missing (the scene file, relative to the study file)")
    spec = Spec(where, text, data)
    spec.base = base
    spec.scene_path = os.path.normpath(os.path.join(base, str(data["scene"])))
    spec.kind = data.get("kind", "hold")
    if spec.kind not in KINDS:
        _fail(where, line("kind"), "kind", f"{spec.kind!r} is not one of {', '.join(KINDS)}")
    for k, lo in (("seed", 0), ("draws", 1), ("chunk", 1)):
        x = data.get(k, {"seed": 0, "draws": 1, "chunk": 32}[k])
        if isinstance(x, bool) or not isinstance(x, int) or x < lo:
            _fail(where, line(k), k, f"a whole number >= {lo}")
        setattr(spec, k, x)
    import coopdyn
    try:
        spec.scene = coopdyn.load_scene(spec.scene_path)
    except Exception as e:  # SceneError 'file:line:col: reason', or the file is missing
        _fail(where, line("scene"), "scene", f"the scene does not load: {e}")
    variables = data.get("variables") or _Lined({}, {}, 1)
    if not isinstance(variables, _Lined):
        _fail(where, line("variables"), "variables", "a mapping name -> {sampler: [...]}")
    q_names = list(spec.scene.q_names)
    v_names = list(spec.scene.v_names)
    spec.variables = [_variable(where, n, b, variables.lines[n], q_names, v_names) for n, b in variables.items()]
    names = [v.name for v in spec.variables]
    has_load = any(n in LOAD_OFFSETS + ("load.mass",) + ERRORS for n in names) or spec.kind == "payload"
    if has_load and "load" not in "".join(q_names[:1]):
        _fail(where, line("scene"), "scene", "load variables and the payload need a scene whose floating root "
              "is the load (formulation mobile_platform)")
    joints = [n for n in names if n in q_names and n not in LOAD_OFFSETS]
    if any(n in LOAD_OFFSETS for n in names) and joints:
        n = joints[0]
        _fail(where, variables.lines[n], f"variables.{n}", "joint states and load offsets exclude each other "
              "(the arms' joints follow the load)")
    if spec.draws_vars and "draws" not in data:
        v = spec.draws_vars[0]
        _fail(where, variables.lines[v.name], f"variables.{v.name}", "a random variable needs draws: N at the top")
    for n in names:
        if n.startswith("tau.") and spec.kind != "evaluate":
            _fail(where, variables.lines[n], f"variables.{n}", "torque variables need kind: evaluate")
        if spec.kind == "evaluate" and not (n.startswith("tau.") or n in q_names and n not in LOAD_OFFSETS):
            _fail(where, variables.lines[n], f"variables.{n}", "kind evaluate takes joint states and tau.<joint> only")
    if spec.kind == "payload" and "load.mass" in names:
        _fail(where, variables.lines["load.mass"], "variables.load.mass", "the payload study finds the mass itself")
    return spec
