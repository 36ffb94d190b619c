"""Parameter sweeps on Dask: one scene run many times with parameters varied by JSON pointer, each
run one task (a `cutsim` process writing its usual run folder), on a local cluster of processes or
on any cluster a Dask scheduler runs. The sweep file, the quantities extracted from each run, the
results folder and how to run on a cluster: docs/sweeps.md.

    cutsim-sweep SWEEP.json [--scheduler tcp://HOST:PORT] [--workers N] [--results DIR]

    import cutsim
    rows = cutsim.sweep("examples/sweeps/tearing.json")

Nothing is lost: a run that fails is a row with its error; a run whose worker dies is given to
another worker and resumes from its last checkpoint; a sweep stopped and started again skips the
runs it finished (a run is named by a hash of its scene, so a changed scene runs again).
"""
import ast
import asyncio
import bisect
import concurrent.futures
import contextlib
import copy
import csv
import hashlib
import importlib.util
import io
import itertools
import json
import math
import os
import re
import shlex
import signal
import shutil
import subprocess
import sys
import threading
import time
import uuid
import warnings

import numpy as np

__all__ = ["sweep", "load_sweep", "prepare", "main", "Sweep", "Run", "Rows"]

_VERSION_CACHE = {}
_EXTRACTOR_CACHE = {}


class _Input(Exception):
    """Bad input in a sweep (its file, its scene or its results folder): FILE:LINE: /pointer: message."""


# ---------------------------------------------------------------------------------------------
# JSON with the line of each value (for FILE:LINE: /pointer: message)
# ---------------------------------------------------------------------------------------------

def _escape(key):
    return str(key).replace("~", "~0").replace("/", "~1")


def _unescape(token):
    return token.replace("~1", "/").replace("~0", "~")


class _Doc:
    """A JSON document with the line of every value, by JSON pointer."""

    _ws = re.compile(r"[ \t\n\r]*")

    def __init__(self, text, source):
        self.source = source
        self.lines = {}
        self._text = text
        self._starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self._decoder = json.JSONDecoder(parse_constant=self._constant)
        try:
            i = self._skip(0)
            self.value, i = self._value(i, "")
            i = self._skip(i)
            if i != len(text):
                self._fail_at(i, "", "unexpected text after the JSON value")
        except json.JSONDecodeError as e:
            raise _Input(f"{source}:{e.lineno}: /: not valid JSON: {e.msg} (column {e.colno})") from None

    def _constant(self, name):
        raise json.JSONDecodeError(f"{name} is not a JSON number", self._text, self._pos)

    def _line(self, i):
        return bisect.bisect_right(self._starts, i)

    def _fail_at(self, i, pointer, message):
        raise _Input(f"{self.source}:{self._line(i)}: {pointer or '/'}: {message}")

    def _skip(self, i):
        return self._ws.match(self._text, i).end()

    def _value(self, i, pointer, depth=0):
        self.lines[pointer] = self._line(i)
        t = self._text
        if depth > 256:
            self._fail_at(i, pointer, "values nested deeper than 256 levels")
        if i >= len(t):
            self._fail_at(i, pointer, "the file ends where a value was expected")
        if t[i] == "{":
            out, keys = {}, set()
            i = self._skip(i + 1)
            if t.startswith("}", i):
                return out, i + 1
            while True:
                if not t.startswith('"', i):
                    self._fail_at(i, pointer, "expected a key in double quotes")
                self._pos = i
                key, i = self._decoder.raw_decode(t, i)
                if key in keys:
                    self._fail_at(i, f"{pointer}/{_escape(key)}", f"the key \"{key}\" is given twice")
                keys.add(key)
                i = self._skip(i)
                if not t.startswith(":", i):
                    self._fail_at(i, pointer, "expected ':' after a key")
                i = self._skip(i + 1)
                out[key], i = self._value(i, f"{pointer}/{_escape(key)}", depth + 1)
                i = self._skip(i)
                if t.startswith(",", i):
                    i = self._skip(i + 1)
                elif t.startswith("}", i):
                    return out, i + 1
                else:
                    self._fail_at(i, pointer, "expected ',' or '}'")
        if t[i] == "[":
            out = []
            i = self._skip(i + 1)
            if t.startswith("]", i):
                return out, i + 1
            while True:
                v, i = self._value(i, f"{pointer}/{len(out)}", depth + 1)
                out.append(v)
                i = self._skip(i)
                if t.startswith(",", i):
                    i = self._skip(i + 1)
                elif t.startswith("]", i):
                    return out, i + 1
                else:
                    self._fail_at(i, pointer, "expected ',' or ']'")
        bad = re.match(r"-?(NaN|Infinity)\b", t[i:i + 10])
        if bad:
            self._fail_at(i, pointer, f"{bad.group(0)} is not a finite number (JSON has no NaN or Infinity)")
        self._pos = i
        try:
            v, end = self._decoder.raw_decode(t, i)
        except ValueError as e:
            if isinstance(e, json.JSONDecodeError):
                raise
            self._fail_at(i, pointer, f"not a number this reader takes ({e})")
        if isinstance(v, float) and not math.isfinite(v):
            self._fail_at(i, pointer, f"{t[i:end]} is not a finite number")
        return v, end

    def line(self, pointer):
        """The line of the value at pointer, or of its nearest ancestor that has one."""
        p = pointer
        while p not in self.lines and p:
            p = p.rsplit("/", 1)[0]
        return self.lines.get(p, 1)

    def fail(self, pointer, message):
        raise _Input(f"{self.source}:{self.line(pointer)}: {pointer or '/'}: {message}")


class _DictDoc(_Doc):
    """A sweep given as a dict (from Python): no lines (1 for all)."""

    def __init__(self, value, source):  # noqa: D107  (no parse)
        from . import InvalidInputError, _json
        self.source = source
        self.lines = {}
        try:
            self.value = json.loads(_json(value, source))  # a copy, only JSON values (numpy's too)
        except (TypeError, InvalidInputError) as e:
            raise _Input(f"{source}:1: /: {e}") from None


def _type_name(v):
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(v), "a number")


# ---------------------------------------------------------------------------------------------
# JSON pointers on the scene
# ---------------------------------------------------------------------------------------------

def _tokens(pointer):
    if pointer == "":
        return []
    if not pointer.startswith("/"):
        raise ValueError("a JSON pointer starts with '/'")
    tokens = pointer[1:].split("/")
    for t in tokens:
        if re.search(r"~(?![01])", t):
            raise ValueError(f"\"{t}\": '~' is written ~0 and '/' ~1 in a JSON pointer (RFC 6901)")
    return [_unescape(t) for t in tokens]


def _resolve(scene, pointer, create):
    """(container, key) of pointer in scene; raises ValueError naming what is missing."""
    tokens = _tokens(pointer)
    if not tokens:
        raise ValueError("the empty pointer names the whole scene, not one of its keys")
    node, walked = scene, ""
    for n, tok in enumerate(tokens):
        last = n == len(tokens) - 1
        if isinstance(node, dict):
            if tok not in node and not (last and create):
                keys = ", ".join(sorted(node)) or "none"
                raise ValueError(f"{walked or '/'} has no key \"{tok}\" (its keys: {keys})")
            if last:
                return node, tok
            node = node[tok]
        elif isinstance(node, list):
            if not re.fullmatch(r"0|[1-9][0-9]*", tok) or int(tok) >= len(node):
                raise ValueError(f"{walked or '/'} is an array of {len(node)} entries: \"{tok}\" is not one of its indices")
            if last:
                return node, int(tok)
            node = node[int(tok)]
        else:
            raise ValueError(f"{walked or '/'} is {_type_name(node)}, which has no \"{tok}\"")
        walked += "/" + _escape(tok)
    raise AssertionError("unreachable")


def _set(scene, pointer, value, create=False):
    container, key = _resolve(scene, pointer, create)
    container[key] = copy.deepcopy(value)


# ---------------------------------------------------------------------------------------------
# The sweep file
# ---------------------------------------------------------------------------------------------

_SWEEP_KEYS = {"name", "description", "scene", "steps", "parameters", "combine", "samples", "seed",
               "extract", "results", "checkpointEvery", "timeout"}
_VALUE_KINDS = ("values", "range", "uniform", "logUniform", "integers", "choice")
_RANDOM_KINDS = ("uniform", "logUniform", "integers", "choice")
_REDUCE = ("max", "min", "mean", "final", "first", "argmax", "argmin")
_MESH = ("triangles", "points", "pieces", "minAngle", "minAngleWorld", "borderLength",
         "maxStrain", "area")


class Parameter:
    """One varied parameter: its name (a CSV column), the JSON pointers it sets, its values."""

    def __init__(self, name, pointers, values, create):
        self.name, self.pointers, self.values, self.create = name, pointers, values, create


class Run:
    """One run of a sweep, as extraction functions see it: `index`, `id` (its hash), `dir` (its
    run folder), `scene` (the scene it ran, a dict), `parameters` ({name: value}), `steps` (the
    per-step CSV: {column: numpy array}, numbers as floats, other columns as strings) and
    `final()` (the last frame's surface: a dict of numpy arrays `position`, `rest`, `triangles`,
    and the point arrays the frame holds, such as `velocity` and `strain`)."""

    def __init__(self, index, run_id, folder, scene, parameters):
        self.index, self.id, self.dir = index, run_id, folder
        self.scene, self.parameters = scene, parameters
        self._steps = None
        self._final = None

    @property
    def steps(self):
        if self._steps is None:
            self._steps = _read_steps(os.path.join(self.dir, "steps.csv"))
        return self._steps

    def final(self):
        if self._final is None:
            self._final = _read_final_surface(self.dir)
        return self._final


class Sweep:
    """A checked sweep: its base scene, its runs (index, parameters, scene, id) and what each run
    gives (extract), ready to run (cutsim.sweep, or `cutsim-sweep`)."""

    def __init__(self):
        self.name = ""
        self.source = ""
        self.base_dir = ""
        self.scene_path = ""
        self.parameters = []
        self.runs = []
        self.extract = []
        self.results = ""
        self.checkpoint_every = 0
        self.timeout = None


def _number(doc, v, pointer, what="a number"):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        doc.fail(pointer, f"expected {what}, got {_type_name(v)}")
    return v


def _check_keys(doc, obj, pointer, allowed):
    for k in obj:
        if k not in allowed:
            doc.fail(f"{pointer}/{_escape(k)}", f"unknown key \"{k}\" (expected one of: {', '.join(sorted(allowed))})")


def _parameter(doc, p, at, samples, rng):
    if not isinstance(p, dict):
        doc.fail(at, f"expected an object {{\"pointer\", and one of {', '.join(_VALUE_KINDS)}}}, got {_type_name(p)}")
    _check_keys(doc, p, at, {"name", "pointer", "pointers", "create", *_VALUE_KINDS})
    if ("pointer" in p) == ("pointers" in p):
        doc.fail(at, "give \"pointer\" (one JSON pointer into the scene) or \"pointers\" (several set to the same value)")
    pointers = [p["pointer"]] if "pointer" in p else p["pointers"]
    where = f"{at}/pointer" if "pointer" in p else f"{at}/pointers"
    if not isinstance(pointers, list) or not pointers:
        doc.fail(where, "expected a non-empty array of JSON pointers")
    for i, q in enumerate(pointers):
        if not isinstance(q, str) or not q.startswith("/"):
            doc.fail(where if "pointer" in p else f"{where}/{i}", f"expected a JSON pointer (\"/key/...\"), got {json.dumps(q)}")
    kinds = [k for k in _VALUE_KINDS if k in p]
    if len(kinds) != 1:
        doc.fail(at, f"give exactly one of {', '.join(_VALUE_KINDS)} (got {', '.join(kinds) or 'none'})")
    kind = kinds[0]
    v, vp = p[kind], f"{at}/{kind}"
    if kind == "values":
        if not isinstance(v, list) or not v:
            doc.fail(vp, "expected a non-empty array of values")
        values = v
    elif kind == "range":
        if not isinstance(v, dict):
            doc.fail(vp, "expected {\"from\", \"to\", \"count\"} or {\"from\", \"to\", \"step\"}, and optionally \"scale\": \"log\"")
        _check_keys(doc, v, vp, {"from", "to", "count", "step", "scale"})
        for k in ("from", "to"):
            if k not in v:
                doc.fail(vp, f"missing \"{k}\"")
            _number(doc, v[k], f"{vp}/{k}")
        lo, hi = float(v["from"]), float(v["to"])
        scale = v.get("scale", "linear")
        if scale not in ("linear", "log"):
            doc.fail(f"{vp}/scale", f"expected \"linear\" or \"log\", got {json.dumps(scale)}")
        if ("count" in v) == ("step" in v):
            doc.fail(vp, "give \"count\" (values from \"from\" to \"to\" inclusive) or \"step\"")
        if scale == "log" and (lo <= 0 or hi <= 0):
            doc.fail(vp, "a log range needs \"from\" and \"to\" > 0")
        if "count" in v:
            n = v["count"]
            if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1000000:
                doc.fail(f"{vp}/count", f"expected an integer from 1 to 10^6, got {json.dumps(n)}")
            if n == 1:
                values = [v["from"]]
            elif scale == "log":
                values = [float(f"{x:.12g}") for x in np.geomspace(lo, hi, n)]
            else:
                values = [float(f"{x:.12g}") for x in np.linspace(lo, hi, n)]
        else:
            step = float(_number(doc, v["step"], f"{vp}/step"))
            if scale == "log":
                doc.fail(f"{vp}/step", "a log range is given by \"count\"")
            if step == 0 or (hi - lo) / step < 0:
                doc.fail(f"{vp}/step", f"{step:g} does not lead from {lo:g} to {hi:g}")
            n = int(math.floor((hi - lo) / step * (1 + 1e-12) + 1e-9)) + 1
            if n > 1000000:
                doc.fail(f"{vp}/step", f"{n} values: more than 10^6")
            values = [float(f"{lo + k * step:.12g}") for k in range(n)]
        ints = all(isinstance(v.get(k, 1), int) and not isinstance(v.get(k, 1), bool) for k in ("from", "to", "step"))
        if ints and scale == "linear" and all(float(x).is_integer() for x in values):
            values = [int(round(x)) for x in values]
    else:
        if samples is None:
            doc.fail(vp, f"\"{kind}\" draws random values: give the sweep \"samples\" (how many) and \"seed\"")
        if kind == "choice":
            if not isinstance(v, list) or not v:
                doc.fail(vp, "expected a non-empty array of values to choose from")
            values = [v[int(i)] for i in rng.integers(0, len(v), samples)]
        else:
            if not isinstance(v, list) or len(v) != 2:
                doc.fail(vp, "expected [low, high]")
            lo = _number(doc, v[0], f"{vp}/0")
            hi = _number(doc, v[1], f"{vp}/1")
            if not lo < hi:
                doc.fail(vp, f"expected low < high, got [{lo}, {hi}]")
            if kind == "uniform":
                values = [float(x) for x in rng.uniform(lo, hi, samples)]
            elif kind == "logUniform":
                if lo <= 0:
                    doc.fail(vp, "logUniform needs low > 0")
                values = [float(x) for x in np.exp(rng.uniform(math.log(lo), math.log(hi), samples))]
            else:
                if not all(isinstance(x, int) and not isinstance(x, bool) for x in v):
                    doc.fail(vp, "integers needs integer bounds")
                values = [int(x) for x in rng.integers(lo, hi + 1, samples)]
    name = p.get("name", pointers[0])
    if not isinstance(name, str) or not name:
        doc.fail(f"{at}/name", "expected a non-empty string")
    create = p.get("create", False)
    if not isinstance(create, bool):
        doc.fail(f"{at}/create", "expected true or false")
    return Parameter(name, pointers, values, create), kind


def _compile_condition(text):
    """A condition "COLUMN OP EXPRESSION" (OP: < <= > >= == !=; the expression of numbers, + - * /
    and the column's first, final, max, min, mean): (column, op, expression tree)."""
    m = re.fullmatch(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(<=|>=|==|!=|<|>)\s*(.+?)\s*", text)
    if not m:
        raise ValueError("expected \"COLUMN OP VALUE\", OP one of < <= > >= == != (e.g. \"kinetic_energy < 1e-5\")")
    try:
        tree = ast.parse(m.group(3), mode="eval").body
    except SyntaxError:
        raise ValueError(f"\"{m.group(3)}\" is not an expression (expected \"COLUMN OP VALUE\", e.g. \"kinetic_energy < 1e-5\")") from None
    allowed = {"first", "final", "max", "min", "mean"}

    def check(node):
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div)):
            check(node.left)
            check(node.right)
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            check(node.operand)
        elif isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            pass
        elif isinstance(node, ast.Name) and node.id in allowed:
            pass
        else:
            raise ValueError(f"\"{m.group(3)}\": only numbers, + - * / and the column's {', '.join(sorted(allowed))}")
    check(tree)
    return m.group(1), m.group(2), tree


def _evaluate(node, names):
    if isinstance(node, ast.BinOp):
        a, b = float(_evaluate(node.left, names)), float(_evaluate(node.right, names))
        if isinstance(node.op, ast.Div):
            return a / b if b != 0 else (math.nan if a == 0 else math.copysign(math.inf, a) * math.copysign(1.0, b))
        return {ast.Add: a + b, ast.Sub: a - b, ast.Mult: a * b}[type(node.op)]
    if isinstance(node, ast.UnaryOp):
        v = _evaluate(node.operand, names)
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.Constant):
        return float(node.value)
    return names[node.id]


def _extractor(doc, e, at, sweep_dir):
    if not isinstance(e, dict):
        doc.fail(at, f"expected an object {{\"name\", and \"column\", \"first\", \"mesh\" or \"python\"}}, got {_type_name(e)}")
    _check_keys(doc, e, at, {"name", "column", "at", "reduce", "first", "after", "mesh", "python", "description"})
    name = e.get("name")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.\-]*", name or ""):
        doc.fail(f"{at}/name" if "name" in e else at, "give each quantity a \"name\" (letters, digits, _ . -): its CSV column")
    kinds = [k for k in ("column", "first", "mesh", "python") if k in e]
    if len(kinds) != 1:
        doc.fail(at, f"give one of \"column\" (with \"at\" or \"reduce\"), \"first\", \"mesh\" or \"python\" (got {', '.join(kinds) or 'none'})")
    kind = kinds[0]
    spec = {"name": name, "kind": kind}
    if kind == "column":
        if not isinstance(e["column"], str):
            doc.fail(f"{at}/column", "expected the name of a column of the run's steps.csv")
        spec["column"] = e["column"]
        if ("at" in e) == ("reduce" in e):
            doc.fail(at, f"a column's quantity needs \"at\" (a time, s) or \"reduce\" (one of {', '.join(_REDUCE)})")
        if "at" in e:
            spec["at"] = float(_number(doc, e["at"], f"{at}/at", "a time (s)"))
        else:
            if e["reduce"] not in _REDUCE:
                doc.fail(f"{at}/reduce", f"expected one of {', '.join(_REDUCE)}, got {json.dumps(e['reduce'])}")
            spec["reduce"] = e["reduce"]
    elif kind == "first":
        if not isinstance(e["first"], str):
            doc.fail(f"{at}/first", "expected a condition \"COLUMN OP VALUE\"")
        try:
            _compile_condition(e["first"])
        except ValueError as err:
            doc.fail(f"{at}/first", str(err))
        spec["first"] = e["first"]
        if "after" in e:
            spec["after"] = float(_number(doc, e["after"], f"{at}/after", "a time (s)"))
    elif kind == "mesh":
        if e["mesh"] not in _MESH:
            doc.fail(f"{at}/mesh", f"expected one of {', '.join(_MESH)}, got {json.dumps(e['mesh'])}")
        spec["mesh"] = e["mesh"]
    else:
        ref = e["python"]
        m = re.fullmatch(r"(.+\.py):([A-Za-z_][A-Za-z0-9_]*)", ref) if isinstance(ref, str) else None
        if not m:
            doc.fail(f"{at}/python", "expected \"FILE.py:FUNCTION\" (the file relative to the sweep file)")
        path = os.path.abspath(os.path.join(sweep_dir, m.group(1)))
        if not os.path.isfile(path):
            doc.fail(f"{at}/python", f"no file {path}")
        try:
            fn = _load_function(path, m.group(2))
        except BaseException as err:  # the user's module: whatever it raises on import (sys.exit too)
            doc.fail(f"{at}/python", f"{path}: {type(err).__name__}: {err}")
        if not callable(fn):
            doc.fail(f"{at}/python", f"{m.group(2)} in {path} is not a function")
        spec["python"] = path
        spec["function"] = m.group(2)
    for k in ("at", "reduce") if kind != "column" else ():
        if k in e:
            doc.fail(f"{at}/{k}", f"\"{k}\" goes with \"column\"")
    if "after" in e and kind != "first":
        doc.fail(f"{at}/after", "\"after\" goes with \"first\"")
    return spec


def _load_function(path, name):
    key = (path, _file_digest(path, {}))  # by content: an edited file is loaded again
    module = _EXTRACTOR_CACHE.get(key)
    if module is None:
        spec = importlib.util.spec_from_file_location(f"cutsim_sweep_extract_{len(_EXTRACTOR_CACHE)}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        _EXTRACTOR_CACHE[key] = module
    if not hasattr(module, name):
        raise AttributeError(f"no function {name}")
    return getattr(module, name)


def _absolute_paths(scene, base_dir):
    """The scene's relative file names (its mesh, obstacles' meshes: every "file" key, and "mesh"
    given as a string) made absolute against base_dir, so that the run's scene file can live
    elsewhere; returns the files named (for the run's hash)."""
    files = []

    def fix(container, key):
        v = container[key]
        if isinstance(v, str):
            p = v if os.path.isabs(v) else os.path.normpath(os.path.join(base_dir, v))
            container[key] = p
            files.append(p)

    def walk(node):
        if isinstance(node, dict):
            for k in list(node):
                if k == "file" and isinstance(node[k], str):
                    fix(node, k)
                else:
                    walk(node[k])
        elif isinstance(node, list):
            for v in node:
                walk(v)
    if isinstance(scene.get("mesh"), str):
        fix(scene, "mesh")
    walk(scene)
    return files


def _file_digest(path, cache):
    if path not in cache:
        h = hashlib.sha256()
        try:
            with open(path, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
            cache[path] = h.hexdigest()
        except OSError:
            cache[path] = "missing"
    return cache[path]


def load_sweep(sweep, *, results=None, cutsim_executable=None, check=True):
    """Reads and checks a sweep (a file path, or a dict whose relative paths are taken from the
    current folder): the sweep file's keys, every pointer against the base scene, every run's
    scene through the scene check (an error names the run's parameters), before anything runs.
    Returns a Sweep. Bad input raises cutsim.InvalidInputError("FILE:LINE: /pointer: message")."""
    from . import InvalidInputError
    try:
        return _load_sweep(sweep, results, cutsim_executable, check)
    except _Input as e:
        raise InvalidInputError(str(e)) from None


def _load_sweep(sweep, results, exe, check):
    from . import InvalidInputError, Simulation
    from . import _cutsim
    if isinstance(sweep, dict):
        doc = _DictDoc(sweep, "<sweep dict>")
        sweep_dir = os.getcwd()
        default_name = "sweep"
    elif not isinstance(sweep, (str, os.PathLike)):
        raise _Input(f"a sweep is a sweep file's path or a dict of its keys, not {type(sweep).__name__}")
    else:
        path = os.fspath(sweep)
        try:
            with open(path, encoding="utf-8-sig") as f:
                text = f.read()
        except OSError as e:
            raise _Input(f"{path}:1: /: cannot read the sweep file: {e.strerror}") from None
        except UnicodeDecodeError as e:
            raise _Input(f"{path}:1: /: not UTF-8 text (byte {e.start}: {e.reason})") from None
        doc = _Doc(text, path)
        sweep_dir = os.path.dirname(os.path.abspath(path))
        default_name = os.path.splitext(os.path.basename(path))[0]
    s = doc.value
    if not isinstance(s, dict):
        doc.fail("", f"a sweep is an object {{\"scene\", \"parameters\", \"extract\", ...}}, got {_type_name(s)}")
    _check_keys(doc, s, "", _SWEEP_KEYS)
    out = Sweep()
    out.source = doc.source
    out.name = s.get("name", default_name)
    if not isinstance(out.name, str) or not re.fullmatch(r"[^/\\\x00-\x1f]{1,200}", out.name) or out.name in (".", ".."):
        doc.fail("/name", f"expected a name without '/' or '\\' (1 to 200 characters), got {json.dumps(out.name)}")
    # The base scene: JSON, or SOFA's .scn through its JSON translation.
    if "scene" not in s or not isinstance(s["scene"], str):
        doc.fail("/scene" if "scene" in s else "", "give \"scene\": the base scene file (.json or .scn), relative to the sweep file")
    scene_path = os.path.normpath(os.path.join(sweep_dir, s["scene"]))
    out.scene_path = scene_path
    out.base_dir = os.path.dirname(scene_path)
    if not os.path.isfile(scene_path):
        doc.fail("/scene", f"no scene file {scene_path}")
    try:
        if scene_path.lower().endswith(".scn"):
            base = json.loads(_cutsim._sofa_scene_json(scene_path))
            if "steps" in s:
                steps = s["steps"]
                if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
                    doc.fail("/steps", "expected a number of steps >= 1")
                base["duration"] = steps * base.get("timeStep", 0.01)
        else:
            if "steps" in s:
                doc.fail("/steps", "\"steps\" is for a SOFA scene (.scn); a JSON scene has its \"duration\"")
            with open(scene_path, encoding="utf-8-sig") as f:
                base = _Doc(f.read(), scene_path).value  # duplicate keys, NaN: refused with their lines
        if check:  # the base scene as it is, so that its own errors are named at its own lines
            with _memory_unchecked():
                Simulation(scene_path)
    except _Input as e:
        doc.fail("/scene", f"the base scene: {e}")
    except InvalidInputError as e:
        doc.fail("/scene", f"the base scene: {e}")
    except (OSError, ValueError) as e:
        doc.fail("/scene", f"{scene_path}: {e}")
    if not isinstance(base, dict):
        doc.fail("/scene", f"{scene_path} is not a scene (a JSON object)")

    samples = s.get("samples")
    if samples is not None and (isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= 1000000):
        doc.fail("/samples", f"expected an integer from 1 to 10^6, got {json.dumps(samples)}")
    seed = s.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        doc.fail("/seed", f"expected an integer >= 0, got {json.dumps(seed)}")
    if samples is not None and "seed" not in s:
        doc.fail("/samples", "random samples need a \"seed\" (the same seed, the same runs)")
    rng = np.random.default_rng(seed)
    columns = {"run", "status", "error", "wall_time_s", "steps", "flagged_steps", "resumed", "folder"}

    params = s.get("parameters")
    if not isinstance(params, list) or not params:
        doc.fail("/parameters" if "parameters" in s else "", "give \"parameters\": a non-empty array of {\"pointer\", \"values\" | \"range\" | ...}")
    kinds = []
    names = set()
    for i, p in enumerate(params):
        param, kind = _parameter(doc, p, f"/parameters/{i}", samples, rng)
        if param.name in names:
            doc.fail(f"/parameters/{i}", f"two parameters named \"{param.name}\" (give each a \"name\")")
        if param.name in columns:
            doc.fail(f"/parameters/{i}/name" if "name" in p else f"/parameters/{i}",
                     f"\"{param.name}\" is a column of the results table already: give the parameter another \"name\"")
        for q in param.pointers:
            for o in out.parameters:
                if any(q == r or q.startswith(r + "/") or r.startswith(q + "/") for r in o.pointers):
                    doc.fail(f"/parameters/{i}", f"{q} is set by the parameter \"{o.name}\" too: one parameter a key")
        names.add(param.name)
        for j, q in enumerate(param.pointers):
            try:
                _resolve(base, q, param.create)
            except ValueError as e:
                qp = f"/parameters/{i}/pointer" if "pointer" in p else f"/parameters/{i}/pointers/{j}"
                doc.fail(qp, f"{q} names no key of the scene {scene_path}: {e}"
                         + ("" if param.create else " (\"create\": true adds a key the scene leaves to its default)"))
        out.parameters.append(param)
        kinds.append(kind)
    if samples is not None and not any(k in _RANDOM_KINDS for k in kinds):
        doc.fail("/samples", f"no parameter draws random values ({', '.join(_RANDOM_KINDS)}): \"samples\" would do nothing")
    combine = s.get("combine", "zip" if samples is not None else "grid")
    if combine not in ("grid", "zip"):
        doc.fail("/combine", f"expected \"grid\" (every combination) or \"zip\" (the i-th value of each together), got {json.dumps(combine)}")
    if combine == "zip":
        counts = {len(p.values) for p in out.parameters}
        if len(counts) > 1:
            doc.fail("/combine", "\"zip\" takes the parameters' values together: they must have as many values each (got "
                     + ", ".join(f"{p.name}: {len(p.values)}" for p in out.parameters) + ")")
        combos = list(zip(*[p.values for p in out.parameters]))
    else:
        total = math.prod(len(p.values) for p in out.parameters)
        if total > 1000000:
            doc.fail("/parameters", f"{total} runs: more than 10^6")
        combos = list(itertools.product(*[p.values for p in out.parameters]))

    extract = s.get("extract", [])
    if not isinstance(extract, list):
        doc.fail("/extract", "expected an array of quantities")
    seen = set(names) | columns
    for i, e in enumerate(extract):
        spec = _extractor(doc, e, f"/extract/{i}", sweep_dir)
        if spec["name"] in seen:
            doc.fail(f"/extract/{i}/name", f"\"{spec['name']}\" is already a column (a parameter's or the table's own)")
        seen.add(spec["name"])
        out.extract.append(spec)

    every = s.get("checkpointEvery", 0)  # 0: a checkpoint only when the run is stopped (its worker dying)
    if isinstance(every, bool) or not isinstance(every, int) or not 0 <= every <= 1000000000:
        doc.fail("/checkpointEvery", f"expected a number of steps from 1 to 10^9 (0: none but the one written when a run is stopped), got {json.dumps(every)}")
    out.checkpoint_every = every
    timeout = s.get("timeout")
    if timeout is not None:
        out.timeout = float(_number(doc, timeout, "/timeout", "a number of seconds"))
        if out.timeout <= 0:
            doc.fail("/timeout", "expected a number of seconds > 0")
    res = os.fspath(results) if results is not None else s.get("results", os.path.join("out", "sweeps", out.name))
    if not isinstance(res, str) or not res:
        doc.fail("/results", "expected a folder name")
    out.results = os.path.abspath(os.path.join(sweep_dir, res) if results is None and "results" in s else res)

    # Every run's scene, checked as `cutsim run` would check it, before anything runs (beyond
    # 2,000 runs: each parameter's every value once and 1,000 runs drawn with a fixed seed, said).
    exe_path = _find_cutsim(exe)
    version = _cutsim_version(exe_path)
    identity = version + "\0" + _file_digest(exe_path, {})  # a rebuilt cutsim makes new runs
    to_check = set(range(len(combos)))
    if check and len(combos) > 2000:
        to_check = set(np.random.default_rng(0).choice(len(combos), 1000, replace=False).tolist())
        for j, p in enumerate(out.parameters):  # every value of each parameter at least once
            seen_values = set()
            for index, combo in enumerate(combos):
                key = json.dumps(combo[j], sort_keys=True)
                if key not in seen_values:
                    seen_values.add(key)
                    to_check.add(index)
        sys.stderr.write(f"cutsim-sweep: {len(combos)} runs: checking the scenes of {len(to_check)} of them "
                         "(every value of each parameter, and 1,000 runs drawn at random)\n")
    digests = {}
    for index, combo in enumerate(combos):
        scene = copy.deepcopy(base)
        values = {}
        for p, v in zip(out.parameters, combo):
            for q in p.pointers:
                _set(scene, q, v, p.create)
            values[p.name] = v
        # The run folder's name of the scene is the base scene's (not the run's scene file's).
        if "name" not in scene:
            scene["name"] = os.path.splitext(os.path.basename(scene_path))[0]
        files = _absolute_paths(scene, out.base_dir)
        label = ", ".join(f"{k} = {json.dumps(v)}" for k, v in values.items())
        if check and index in to_check:
            try:
                with _memory_unchecked():
                    Simulation(scene, base_dir=out.base_dir, source="RUN")
            except InvalidInputError as e:
                # "RUN:LINE: /pointer: message" (or without a line): the pointer and the message,
                # at the parameter that sets that pointer (or the parameters).
                m = re.match(r"^RUN(?::\d+)?: (/\S*): (.*)$", str(e), re.S)
                where, what = (m.group(1), m.group(2)) if m else ("", str(e).replace("RUN: ", "", 1))
                at = "/parameters"
                for i, p in enumerate(out.parameters):
                    if where and any(where == q or where.startswith(q + "/") or q.startswith(where + "/") for q in p.pointers):
                        at = f"/parameters/{i}"
                        break
                doc.fail(at, f"the scene check refuses run {index} ({label}): {where + ': ' if where else ''}{what}")
        canonical = json.dumps(scene, sort_keys=True, separators=(",", ":"))
        h = hashlib.sha256()
        h.update(identity.encode())
        h.update(b"\0")
        h.update(canonical.encode())
        for f in sorted(set(files)):
            h.update(b"\0" + f.encode() + b"\0" + _file_digest(f, digests).encode())
        run_id = h.hexdigest()[:16]
        out.runs.append({"index": index, "id": run_id, "values": values, "scene": scene, "label": label})
    out.version = version
    # What the quantities depend on besides the run: their specs and the Python files' contents.
    code = {e["python"]: _file_digest(e["python"], {}) for e in out.extract if e["kind"] == "python"}
    out.extract_key = hashlib.sha256(json.dumps([out.extract, code], sort_keys=True).encode()).hexdigest()[:16]
    out.results_line = doc.line("/results") if "results" in s and results is None else None
    return out


# ---------------------------------------------------------------------------------------------
# Finding and running cutsim (on the worker)
# ---------------------------------------------------------------------------------------------

def _find_cutsim(hint=None):
    """The cutsim program: hint, $CUTSIM_EXECUTABLE, next to this package (the build tree's
    src/cutsim, or an install prefix's bin/cutsim), or the first on PATH."""
    here = os.path.dirname(os.path.abspath(__file__))
    if hint is not None:
        if os.path.isfile(hint) and os.access(hint, os.X_OK):
            return os.path.abspath(hint)
        raise FileNotFoundError(f"--cutsim {hint}: not an executable file")
    candidates = [os.environ.get("CUTSIM_EXECUTABLE"),
                  os.path.join(here, "..", "..", "src", "cutsim")]
    # prefix/lib/python3.X/{dist,site}-packages/cutsim -> prefix/bin/cutsim
    candidates.append(os.path.join(here, "..", "..", "..", "..", "bin", "cutsim"))
    candidates.append(shutil.which("cutsim"))
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    raise FileNotFoundError("no cutsim program found (looked at $CUTSIM_EXECUTABLE, next to the Python package and on PATH): "
                            "set CUTSIM_EXECUTABLE or give --cutsim")


def _cutsim_version(exe):
    if exe not in _VERSION_CACHE:
        r = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
        _VERSION_CACHE[exe] = r.stdout.strip()
    return _VERSION_CACHE[exe]


def _paths(results, run_id):
    runs = os.path.join(results, "runs")
    return {"dir": os.path.join(runs, run_id), "scene": os.path.join(runs, run_id + ".scene.json"),
            "result": os.path.join(runs, run_id + ".result.json"), "log": os.path.join(runs, run_id + ".log"),
            "lock": os.path.join(runs, "." + run_id + ".lock"),
            "seconds": os.path.join(runs, "." + run_id + ".seconds")}


def _write_atomic(path, text):
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _last_error(log_path):
    try:
        with open(log_path, encoding="utf-8", errors="replace") as f:
            lines = [ln.strip() for ln in f if ln.strip()]
    except OSError:
        return ""
    for ln in reversed(lines):
        if "error" in ln.lower() or "cutsim:" in ln:
            return ln
    return lines[-1] if lines else ""


def _run_task(task):
    """One run, in a worker: waits for the run's lock (an earlier attempt's cutsim, orphaned when
    its worker died, writes its checkpoint on the way out and frees it), resumes from the run's
    checkpoint or runs from the start, then extracts the quantities. Returns the run's row; never
    raises for a run that fails (the row says why)."""
    import fcntl
    p = _paths(task["results"], task["id"])
    lock = open(p["lock"], "a+")
    try:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX)
        prior = _read_result(p["result"])
        if prior is not None and prior.get("status") == "failed":
            return prior  # (--retry-failed: the sweep removes it before asking again)
        if prior is not None and prior.get("status") == "done" and prior.get("extract_key") == task["extract_key"]:
            return prior
        row = {"index": task["index"], "id": task["id"], "values": task["values"], "resumed": False,
               "wall_time_s": 0.0, "extract_key": task["extract_key"]}
        if prior is not None and prior.get("status") == "done":  # its quantities again
            row.update(status="done", error="", wall_time_s=prior.get("wall_time_s"),
                       resumed=prior.get("resumed", False))
        elif _finished_folder(p["dir"]):
            # Run to its end but not recorded (a job array running the prepared commands, or a
            # worker gone right after its run ended): the folder is the run's (named by its
            # scene's hash); only its quantities are wanted.
            _remove(os.path.join(p["dir"], "checkpoint.ckpt"))
            row.update(status="done", error="", wall_time_s=None)
        elif task.get("extract_only"):
            return dict(row, status="stopped", error="its run folder is not finished")
        else:
            row.update(_execute(task, p, lock))
        if row["status"] == "stopped":
            return row  # no result: the next attempt or the next sweep goes on from its checkpoint
        if row["status"] == "done":
            row.update(_extract_all(task, p))
        _write_atomic(p["result"], json.dumps(row, indent=1, sort_keys=True))
        _remove(p["seconds"])
        return row
    finally:
        lock.close()


def _remove(path):
    try:
        os.remove(path)
    except FileNotFoundError:
        pass


def _finished_folder(folder):
    """A run folder that `cutsim run` finished: steps.csv written (at its end) and nothing partial
    (a checkpoint may be left: `--checkpoint-every` keeps the last one)."""
    try:
        names = os.listdir(folder)
    except OSError:
        return False
    return "steps.csv" in names and not any(".partial." in n or n.endswith(".tmp") for n in names)


def _execute(task, p, lock):
    try:
        exe = _find_cutsim(task.get("cutsim"))
        version = _cutsim_version(exe)
    except (OSError, subprocess.SubprocessError) as e:  # this worker's set-up, not the run's failure
        return {"status": "stopped", "error": f"on {os.uname().nodename}: {e}"}
    if version != task["version"]:
        return {"status": "stopped", "error": f"on {os.uname().nodename}: {exe} is \"{version}\", the sweep was made with \"{task['version']}\""}
    ckpt = os.path.join(p["dir"], "checkpoint.ckpt")
    resumed = os.path.isfile(ckpt)
    if resumed:
        cmd = [exe, "resume", ckpt, "--quiet"]
    else:
        cmd = _run_command(exe, p, task)
    spent = _read_result(p["seconds"]) or 0.0  # earlier attempts stopped midway
    status, error, seconds = _call(cmd, p, lock, task.get("timeout"))
    if resumed and status == "bad-input":
        # A checkpoint this build cannot read (damaged, another build): the run from its start.
        cmd = _run_command(exe, p, task)
        resumed = False
        status, error, more = _call(cmd, p, lock, task.get("timeout"))
        seconds += more
    seconds += spent
    if status == "stopped":
        _write_atomic(p["seconds"], json.dumps(round(seconds, 3)))
    if status == "done":
        _remove(ckpt)  # the run folder is then the one `cutsim run` writes
        if not os.path.isfile(os.path.join(p["dir"], "steps.csv")):
            status, error = "failed", "cutsim ended without its steps.csv"
    return {"status": status if status in ("done", "stopped") else "stopped" if status == "timeout" else "failed",
            "timeout": status == "timeout", "error": error,
            "wall_time_s": round(seconds, 3), "resumed": resumed}


def _run_command(exe, p, task):
    cmd = [exe, "run", p["scene"], "--out", p["dir"], "--quiet"]
    if task["checkpoint_every"]:
        cmd += ["--checkpoint-every", str(task["checkpoint_every"])]
    return cmd


@contextlib.contextmanager
def _memory_unchecked():
    """The sweep's check of its scenes, without the memory check: the runs may go to other
    machines (Dask's workers), whose own `cutsim run` checks their memory. The environment's
    CUTSIM_MEMORY, when set, is kept."""
    if "CUTSIM_MEMORY" in os.environ:
        yield
        return
    os.environ["CUTSIM_MEMORY"] = "off"
    try:
        yield
    finally:
        os.environ.pop("CUTSIM_MEMORY", None)


def _call(cmd, p, lock, timeout):
    # The run's process ends with its worker: SIGTERM when the thread that started it dies (the
    # run then writes a checkpoint and stops, and the lock it holds frees the next attempt).
    prefix = ["setpriv", "--pdeathsig", "TERM"] if shutil.which("setpriv") else []
    start = time.monotonic()
    with open(p["log"], "a", encoding="utf-8") as log:
        log.write(f"$ {' '.join(cmd)}\n")
        log.flush()
        # One thread a run (a worker a core runs one each), unless the sweep's environment says.
        env = dict(os.environ)
        env.setdefault("CUTSIM_THREADS", "1")
        proc = subprocess.Popen(prefix + cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                pass_fds=(lock.fileno(),), env=env)
        try:
            code = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            # Stopped as Ctrl-C would stop it: a checkpoint, from which the next attempt goes on.
            proc.terminate()
            try:
                proc.wait(timeout=120)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            return "timeout", f"stopped after its timeout of {timeout:g} s (run the sweep again to go on from its checkpoint)", time.monotonic() - start
        except BaseException:
            proc.terminate()  # (the worker going: the run writes its checkpoint)
            raise
    seconds = time.monotonic() - start
    if code == 0:
        return "done", "", seconds
    reason = _last_error(p["log"])
    if code == 2:
        return "bad-input", reason, seconds
    if "another run is writing" in reason:  # (a prepared command running it now)
        return "stopped", reason, seconds
    sig = -code if code < 0 else code - 128 if code > 128 else 0
    if sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        # Stopped from outside (its worker or the sweep stopping): it wrote a checkpoint, from
        # which the next attempt goes on.
        return "stopped", f"stopped by {signal.Signals(sig).name} (run the sweep again to go on)", seconds
    if sig:
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else f"signal {sig}"
        return "failed", f"cutsim ended by {name}{' (out of memory?)' if sig == signal.SIGKILL else ''}: {reason}", seconds
    return "failed", reason or f"cutsim exited with code {code}", seconds


def _read_result(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


# ---------------------------------------------------------------------------------------------
# What a run gives
# ---------------------------------------------------------------------------------------------

def _read_steps(path):
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    if not rows:
        return {}
    header, body = rows[0], rows[1:]
    out = {}
    for j, name in enumerate(header):
        col = [r[j] if j < len(r) else "" for r in body]
        try:
            out[name] = np.array([float(x) for x in col])
        except ValueError:
            out[name] = np.array(col, dtype=object)
    return out


def _read_final_surface(folder):
    with open(os.path.join(folder, "surface.pvd"), encoding="utf-8") as f:
        files = re.findall(r'file="([^"]+)"', f.read())
    if not files:
        raise ValueError("the run wrote no surface frame")
    with open(os.path.join(folder, files[-1]), encoding="utf-8") as f:
        text = f.read()
    arrays = {}
    for m in re.finditer(r'<DataArray([^>]*)>(.*?)</DataArray>', text, re.S):
        name = re.search(r'Name="([^"]+)"', m.group(1)).group(1)
        kind = re.search(r'type="([^"]+)"', m.group(1)).group(1)
        comps = re.search(r'NumberOfComponents="(\d+)"', m.group(1))
        a = np.array(m.group(2).split(), dtype=float if kind.startswith("Float") else np.int64)
        arrays[name] = a.reshape(-1, int(comps.group(1))) if comps else a
    offsets = arrays.pop("offsets")
    conn = arrays.pop("connectivity")
    if not np.all(np.diff(np.concatenate([[0], offsets])) == 3):
        raise ValueError("the surface frame holds polygons that are not triangles")
    out = {"triangles": conn.reshape(-1, 3), "position": arrays.pop("position")}
    out["rest"] = arrays.pop("rest_position", out["position"])
    out.update(arrays)
    return out


def _min_angle(x, tri):
    if len(tri) == 0:
        return float("nan")
    a, b, c = x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]
    worst = np.full(len(tri), np.inf)
    for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
        u, v = q - p, r - p
        cosang = np.einsum("ij,ij->i", u, v) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        worst = np.minimum(worst, np.degrees(np.arccos(np.clip(cosang, -1, 1))))
    return float(worst.min())


def _pieces(tri):
    parent = {}

    def find(a):
        root = a
        while parent.setdefault(root, root) != root:
            root = parent[root]
        while parent[a] != root:
            parent[a], a = root, parent[a]
        return root
    for a, b, c in tri.tolist():
        ra, rb, rc = find(a), find(b), find(c)
        parent[rb] = ra
        parent[find(rc)] = ra
    return len({find(p) for p in parent})


def _mesh_measure(final, what):
    tri, x, rest = final["triangles"], final["position"], final["rest"]
    if what == "triangles":
        return int(len(tri))
    if what == "points":
        return int(len(np.unique(tri)))
    if what == "pieces":
        return _pieces(tri)
    if what == "minAngle":
        return _min_angle(rest, tri)
    if what == "minAngleWorld":
        return _min_angle(x, tri)
    if what == "area":
        return float(0.5 * np.linalg.norm(np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]]), axis=1).sum())
    if what == "borderLength":
        e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        unique, count = np.unique(e, axis=0, return_counts=True)
        b = unique[count == 1]
        return float(np.linalg.norm(rest[b[:, 0]] - rest[b[:, 1]], axis=1).sum())
    if what == "maxStrain":
        if "strain" not in final:
            raise ValueError("the surface frame holds no strain")
        return float(np.max(final["strain"]))
    raise ValueError(what)


def _column(steps, name):
    if name not in steps:
        raise ValueError(f"no column \"{name}\" in steps.csv (its columns: {', '.join(steps)})")
    c = steps[name]
    if c.dtype == object:
        raise ValueError(f"the column \"{name}\" is not numeric")
    return c


def _extract_one(spec, run):
    kind = spec["kind"]
    if kind == "column":
        c, t = _column(run.steps, spec["column"]), _column(run.steps, "time")
        if "at" in spec:
            if not t[0] - 1e-12 <= spec["at"] <= t[-1] + 1e-12:
                raise ValueError(f"t = {spec['at']:g} s is outside the run ({t[0]:g} to {t[-1]:g} s)")
            return float(np.interp(spec["at"], t, c))
        r = spec["reduce"]
        if r == "argmax":
            return float(t[int(np.argmax(c))])
        if r == "argmin":
            return float(t[int(np.argmin(c))])
        return float({"max": np.max, "min": np.min, "mean": np.mean, "final": lambda a: a[-1], "first": lambda a: a[0]}[r](c))
    if kind == "first":
        name, op, tree = _compile_condition(spec["first"])
        c, t = _column(run.steps, name), _column(run.steps, "time")
        bound = _evaluate(tree, {"first": c[0], "final": c[-1], "max": c.max(), "min": c.min(), "mean": c.mean()})
        if not math.isfinite(bound):
            raise ValueError(f"the condition's value \"{spec['first'].split(op, 1)[1].strip()}\" is {bound}, not a finite number")
        ok = {"<": c < bound, "<=": c <= bound, ">": c > bound, ">=": c >= bound, "==": c == bound, "!=": c != bound}[op]
        ok &= t >= spec.get("after", -np.inf)
        hits = np.nonzero(ok)[0]
        return float(t[hits[0]]) if hits.size else None
    if kind == "mesh":
        return _mesh_measure(run.final(), spec["mesh"])
    value = _load_function(spec["python"], spec["function"])(run)
    if isinstance(value, (np.generic,)):
        value = value.item()
    if value is not None and not isinstance(value, (int, float, str, bool)):
        raise ValueError(f"{spec['function']} returned {type(value).__name__}: a number, a string or None is expected")
    return value


def _extract_all(task, p):
    with open(p["scene"], encoding="utf-8") as f:
        scene = json.load(f)
    run = Run(task["index"], task["id"], p["dir"], scene, task["values"])
    out, errors = {}, []
    try:
        flags = run.steps.get("solver_flags")
        out["steps"] = max(0, len(run.steps.get("time", [])) - 1)
        out["flagged_steps"] = int(sum(1 for f in flags[1:] if f != "ok")) if flags is not None else 0
    except OSError as e:
        return {"quantities": {}, "error": f"steps.csv: {e}"}
    for spec in task["extract"]:
        try:
            with np.errstate(all="ignore"):
                v = _extract_one(spec, run)
            if isinstance(v, float) and not math.isfinite(v):
                raise ValueError(f"{v} is not a finite number")
            out[spec["name"]] = v
        except Exception as e:  # a quantity that cannot be had is named in the row, the others kept
            out[spec["name"]] = None
            errors.append(f"{spec['name']}: {e}" if isinstance(e, ValueError) else f"{spec['name']}: {type(e).__name__}: {e}")
    result = {"quantities": out}
    if errors:
        result["error"] = "; ".join(errors)
    return result


# ---------------------------------------------------------------------------------------------
# The results folder, the table, the picture
# ---------------------------------------------------------------------------------------------

_MARKER = ".cutsim-sweep.json"
_OWN = {_MARKER, "results.csv", "summary.png", "runs", "commands.txt"}


def _results_error(sw, message):
    where = f"{sw.source}:{sw.results_line}: /results" if sw.results_line else f"the results folder {sw.results}"
    return _Input(f"{where}: {message}")


def _check_results(sw):
    """Refuses a results folder that is a file, holds another sweep's results or files that are
    not a sweep's (this one's sweep file among them); changes nothing."""
    if os.path.exists(sw.results) and not os.path.isdir(sw.results):
        raise _results_error(sw, f"{sw.results} is a file, not a folder")
    try:
        names = os.listdir(sw.results) if os.path.isdir(sw.results) else []
    except OSError as e:
        raise _results_error(sw, f"cannot read {sw.results}: {e.strerror}") from None
    foreign = sorted(n for n in names if n not in _OWN and not n.endswith(".tmp") and not n.endswith(".tmp.png"))
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise _results_error(sw, f"{sw.results} holds files that are not a sweep's results ({shown}): "
                                 "give another folder (\"results\", or --results)")
    if names:
        mine = _read_result(os.path.join(sw.results, _MARKER))
        if mine is None:
            raise _results_error(sw, f"{sw.results} holds files of a sweep's results folder but not its mark "
                                     f"({_MARKER}): give another folder")
        if (mine.get("name"), mine.get("scene"), mine.get("source")) != (sw.name, sw.scene_path, _source_of(sw)):
            raise _results_error(sw, f"{sw.results} holds the results of another sweep (\"{mine.get('name')}\" of "
                                     f"{mine.get('scene')}, from {mine.get('source')}): give another folder "
                                     "(\"results\", or --results)")


def _source_of(sw):
    return os.path.abspath(sw.source) if os.path.exists(sw.source) else sw.source


def _claim(sw, sweep_text):
    """Makes sw.results this sweep's folder (after _check_results)."""
    _check_results(sw)
    try:
        os.makedirs(os.path.join(sw.results, "runs"), exist_ok=True)
        _write_atomic(os.path.join(sw.results, _MARKER),
                      json.dumps({"name": sw.name, "source": _source_of(sw),
                                  "scene": sw.scene_path, "cutsim": sw.version, "sweep": sweep_text}, indent=1))
    except OSError as e:
        raise _results_error(sw, f"cannot write there: {e.strerror or e}") from None


def _csv_value(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (dict, list)):
        return json.dumps(v)
    return str(v)


def _columns(sw):
    return (["run", "status", "error"] + [p.name for p in sw.parameters] + [e["name"] for e in sw.extract]
            + ["wall_time_s", "steps", "flagged_steps", "resumed", "folder"])


def _table_row(sw, row):
    q = row.get("quantities", {})
    r = {"run": row["index"], "status": row["status"], "error": row.get("error", ""),
         "wall_time_s": row.get("wall_time_s"), "steps": q.get("steps"), "flagged_steps": q.get("flagged_steps"),
         "resumed": "yes" if row.get("resumed") else "no",
         "folder": os.path.join("runs", row["id"])}
    for p in sw.parameters:
        r[p.name] = row["values"].get(p.name)
    for e in sw.extract:
        r[e["name"]] = q.get(e["name"])
    return r


def _write_table(sw, rows):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = _columns(sw)
    w.writerow(cols)
    for index in sorted(rows):
        r = _table_row(sw, rows[index])
        w.writerow([_csv_value(r[c]) for c in cols])
    _write_atomic(os.path.join(sw.results, "results.csv"), buf.getvalue())


def _plot(sw, rows):
    """summary.png: each quantity (and the wall time) against each varied parameter."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    quantities = [e["name"] for e in sw.extract] + ["wall_time_s"]
    varied = [p for p in sw.parameters if len({json.dumps(v, sort_keys=True) for v in p.values}) > 1] or sw.parameters
    table = [_table_row(sw, rows[i]) for i in sorted(rows)]
    nq, npar = len(quantities), len(varied)
    if npar == 1:  # one parameter: the quantities side by side, three a row
        cols = min(3, nq)
        grid_rows = -(-nq // cols)
        fig, grid = plt.subplots(grid_rows, cols, figsize=(3.8 * cols + 0.4, 2.8 * grid_rows + 0.8), squeeze=False)
        for k in range(nq, grid_rows * cols):
            grid[k // cols][k % cols].set_visible(False)

        def panel(i, j):
            return grid[i // cols][i % cols]

        def labelled(i, j):
            return True, True
    else:  # a row a quantity, a column a parameter
        fig, grid = plt.subplots(nq, npar, figsize=(3.6 * npar + 0.6, 2.6 * nq + 0.8), squeeze=False)

        def panel(i, j):
            return grid[i][j]

        def labelled(i, j):
            return i == nq - 1, j == 0
    failed = sum(1 for r in table if r["status"] == "failed")
    stopped = sum(1 for r in table if r["status"] == "stopped")
    fig.suptitle(f"{sw.name}: {len(table)} runs ({failed} failed{f', {stopped} stopped' if stopped else ''})", fontsize=11)
    palette = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, p in enumerate(varied):
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p.values)
        labels = [] if numeric else sorted({json.dumps(v, sort_keys=True) for v in p.values})

        def short(v):
            text = v if isinstance(v, str) else json.dumps(v, sort_keys=True) if not isinstance(v, float) else f"{v:g}"
            return text if len(text) <= 24 else text[:23] + "~"
        others = [o for o in varied if o is not p]

        def xof(r):
            return r[p.name] if numeric else labels.index(json.dumps(r[p.name], sort_keys=True))

        # One line per combination of the other varied parameters (a grid's slices), when few.
        groups = {}
        for r in table:
            groups.setdefault(tuple(json.dumps(r[o.name]) for o in others), []).append(r)
        lines = 1 < len(groups) <= 8
        for i, q in enumerate(quantities):
            ax = panel(i, j)
            fx, lo = [], math.inf
            for g, (key, members) in enumerate(sorted(groups.items())):
                pts = sorted((xof(r), r[q]) for r in members if r["status"] == "done" and isinstance(r[q], (int, float))
                             and not isinstance(r[q], bool) and math.isfinite(r[q]))
                fx += [xof(r) for r in members if r["status"] != "done"]
                if pts:
                    lo = min(lo, min(y for _, y in pts))
                    label = ", ".join(f"{o.name}={short(json.loads(k))}" for o, k in zip(others, key)) if lines else None
                    ax.plot([x for x, _ in pts], [y for _, y in pts], "o-" if lines or len(groups) == 1 else "o", ms=4, lw=1,
                            color=palette[g % len(palette)] if lines else "#1f77b4", alpha=0.85, label=label)
            if fx:  # at the foot of the plot: a failed run has no value
                from matplotlib.transforms import blended_transform_factory
                ax.plot(fx, [0.03] * len(fx), "x", color="#d62728", ms=7, label="failed or stopped",
                        transform=blended_transform_factory(ax.transData, ax.transAxes), clip_on=False)
            if (lines or fx) and i == 0:
                ax.legend(fontsize=6, loc="best")
            if numeric and len(p.values) > 2 and min(p.values) > 0 and max(p.values) / min(p.values) >= 10:
                ax.set_xscale("log")
                ticks = sorted(set(p.values))
                if len(ticks) <= 8:
                    ax.set_xticks(ticks)
                    ax.set_xticklabels([f"{v:g}" for v in ticks], fontsize=7)
                    ax.minorticks_off()
            if not numeric:
                ax.set_xticks(range(len(labels)))
                ax.set_xticklabels([short(json.loads(lb)) for lb in labels], fontsize=7, rotation=15)
            xl, yl = labelled(i, j)
            if xl:
                ax.set_xlabel(p.name, fontsize=8)
            if yl:
                ax.set_ylabel(q, fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
    path = os.path.join(sw.results, "summary.png")
    fig.savefig(path + ".tmp.png", dpi=100)
    plt.close(fig)
    os.replace(path + ".tmp.png", path)
    return path


# ---------------------------------------------------------------------------------------------
# The sweep on Dask
# ---------------------------------------------------------------------------------------------

class _Progress:
    def __init__(self, total, skipped, stream, enabled):
        self.total, self.skipped, self.stream, self.enabled = total, skipped, stream, enabled
        self.tty = enabled and hasattr(stream, "isatty") and stream.isatty()
        self.start = time.monotonic()
        self.last = 0.0

    def show(self, done, failed, running, final=False):
        if not self.enabled:
            return
        now = time.monotonic()
        if not final and not self.tty and now - self.last < 10.0:
            return
        self.last = now
        finished = done + failed
        new = finished - self.skipped
        elapsed = now - self.start
        left = self.total - finished
        if left == 0:
            eta = "0 s"
        elif new > 0:
            eta = f"{elapsed / new * left:.0f} s"
        else:
            eta = "estimating"
        width = 28
        filled = int(width * finished / max(self.total, 1))
        bar = "#" * filled + "-" * (width - filled)
        text = (f"[{bar}] {finished}/{self.total} runs: {done} done, {failed} failed, {running} running"
                f"{f', {self.skipped} done before' if self.skipped else ''}; {elapsed:.0f} s, left {eta}")
        if self.tty:
            self.stream.write("\r" + text + ("\n" if final else "\x1b[K"))
        else:
            self.stream.write(text + "\n")
        self.stream.flush()


def _client(scheduler, workers, timeout, stream):
    import logging

    import dask
    from distributed import Client, LocalCluster
    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler.strip():
            raise _Input(f"--scheduler: expected a Dask scheduler's address (tcp://HOST:PORT), got {scheduler!r}")
        if not timeout > 0:
            raise _Input(f"--timeout: expected a number of seconds > 0, got {timeout}")
        try:
            return Client(scheduler, timeout=timeout), None
        except (OSError, TimeoutError) as e:
            raise _Input(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s: {e}") from None
        except ValueError as e:
            raise _Input(f"--scheduler {scheduler}: {e}") from None
    n = workers or os.cpu_count() or 1
    warnings.filterwarnings("ignore", message="make_current is deprecated", category=DeprecationWarning)
    # The workers only start cutsim processes and wait for them: their own periodic work (the
    # profiler's stack samples every 10 ms, the memory monitor, work stealing) is turned down so
    # that it does not take the runs' cores; and their environment is the sweep's own (the nanny
    # would set OMP/MKL/OPENBLAS_NUM_THREADS=1 for the runs, which `cutsim run` does not have).
    dask.config.set({"distributed.worker.profile.enabled": False,
                     "distributed.worker.profile.interval": "1s",
                     "distributed.worker.memory.monitor-interval": "1s",
                     "distributed.admin.tick.interval": "200ms",
                     "distributed.scheduler.work-stealing": False,
                     "distributed.nanny.pre-spawn-environ": {}})
    # Ctrl-C is the sweep's to handle: the worker processes start with SIGINT ignored (Python
    # then installs no handler of its own, so they print no KeyboardInterrupt of their own, and
    # their runs keep it ignored too); the sweep then closes the cluster, and each run, sent
    # SIGTERM as its worker goes, writes its checkpoint and stops.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if threading.current_thread() is threading.main_thread() else None
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster


def sweep(sweep, *, results=None, scheduler=None, workers=None, progress=True, retry_failed=False,
          cutsim_executable=None, connect_timeout=10.0, stream=None):
    """Runs a sweep (a sweep file, or a dict: docs/sweeps.md) and returns its rows: one dict per
    run (run, status, error, the parameters, the quantities, wall_time_s, steps, flagged_steps,
    resumed, folder), also written to RESULTS/results.csv as runs finish, with RESULTS/summary.png
    at the end. scheduler: a Dask scheduler's address (tcp://HOST:PORT); by default a local
    cluster of `workers` processes (default: one per core). Runs finished before (same scene,
    same cutsim) are not run again; failed ones only with retry_failed. Raises
    InvalidInputError for a bad sweep, scene or results folder, or an unreachable scheduler."""
    from . import InvalidInputError
    stream = stream if stream is not None else sys.stderr
    try:
        return _sweep(sweep, results, scheduler, workers, progress, retry_failed, cutsim_executable,
                      connect_timeout, stream)
    except _Input as e:
        raise InvalidInputError(str(e)) from None


def _sweep(sweep_in, results, scheduler, workers, progress, retry_failed, exe, connect_timeout, stream):
    sw = _load_sweep(sweep_in, results, exe, True)
    try:
        from distributed import wait
        from distributed.scheduler import KilledWorker
    except ImportError as e:
        raise _Input(f"sweeps run on Dask distributed, which this Python cannot import ({e}): "
                     "install it (Debian: apt-get install python3-distributed; scripts/deps.sh does)") from None
    text = _sweep_text(sweep_in)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise _Input(f"workers: expected a number >= 1, got {workers!r}")
    _check_results(sw)  # before a cluster starts
    with _main_module_hidden():
        client, cluster = _client(scheduler, workers, connect_timeout, stream)
        try:
            return _run_all(sw, text, client, wait, KilledWorker, progress, retry_failed, exe, stream)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


@contextlib.contextmanager
def _main_module_hidden():
    """While a local cluster starts and runs, its worker processes (started by spawning a fresh
    interpreter) are not made to import the caller's main script again: a script that calls
    cutsim.sweep() at its top level would otherwise start clusters in every worker. Only the
    workers' start reads it (multiprocessing's preparation data); cutsim's tasks are in
    cutsim.sweeps, which the workers import by name."""
    main = sys.modules.get("__main__")
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if main is not None and k in main.__dict__}
    try:
        if main is not None:
            main.__dict__.pop("__file__", None)
            if "__spec__" in saved:
                main.__spec__ = None
        yield
    finally:
        if main is not None:
            main.__dict__.update(saved)


def _run_all(sw, text, client, wait, KilledWorker, progress, retry_failed, exe, stream):
    _claim(sw, text)
    by_id = {}
    for run in sw.runs:  # the same scene twice is one run, its row shown for both
        by_id.setdefault(run["id"], []).append(run)
    rows = {}

    def record(run_id, row):
        for run in by_id[run_id]:
            rows[run["index"]] = dict(row, index=run["index"], values=run["values"], id=run_id)

    todo = []
    for run_id, runs in by_id.items():
        p = _paths(sw.results, run_id)
        _write_scene(p, runs[0])
        prior = _read_result(p["result"])
        if prior is not None and prior.get("status") == "failed" and not retry_failed:
            record(run_id, prior)  # (it would fail the same way)
            continue
        if prior is not None and prior.get("status") == "done":
            if prior.get("extract_key") != sw.extract_key:  # its quantities again, nothing run
                prior = _run_task(dict(_task(sw, runs[0], exe), extract_only=True))
            record(run_id, prior)
            continue
        if prior is not None:
            os.remove(p["result"])
        todo.append(runs[0])
    skipped = len(rows)
    _write_table(sw, rows)
    bar = _Progress(len(sw.runs), skipped, stream, progress)
    attempts = {}
    by_run = {run["id"]: run for run in todo}

    def submit(run_id):
        # A key of its own (not the run's id alone): another sweep on the same scheduler, or this
        # one's earlier attempt, is never taken for it; the run's lock keeps them apart on disk.
        attempts[run_id] = attempts.get(run_id, 0) + 1
        f = client.submit(_run_task, _task(sw, by_run[run_id], exe), pure=False,
                          key=f"cutsim-run-{run_id}-{uuid.uuid4().hex[:12]}")
        futures[f] = run_id
        return f

    futures = {}
    pending = {submit(run["id"]) for run in todo}

    def counts():
        ok = sum(1 for r in rows.values() if r["status"] == "done")
        return ok, len(rows) - ok
    bar.show(*counts(), 0)
    waited_alone = time.monotonic()
    try:
        while pending:
            try:
                finished, pending = wait(pending, timeout=1.0, return_when="FIRST_COMPLETED")
            except (TimeoutError, asyncio.TimeoutError):  # nothing finished this second
                finished = set()
            except (concurrent.futures.CancelledError, asyncio.CancelledError):
                # Cancelled by the scheduler (a reconnection, a restart): asked again.
                finished = set()
                pending = {submit(futures[f]) if f.cancelled() else f for f in pending}
            for f in finished:
                run_id = futures[f]
                try:
                    row = f.result()
                except KilledWorker as e:
                    row = {"status": "failed", "error": f"every worker that ran it died ({e})"}
                except concurrent.futures.CancelledError:
                    row = {"status": "stopped", "error": "cancelled by the scheduler"}
                except Exception as e:  # the task itself failed (not the run): its row says so
                    row = {"status": "failed", "error": f"{type(e).__name__}: {e}"}
                if row["status"] == "stopped" and not row.get("timeout") and attempts[run_id] < 3:
                    # Stopped from outside while the sweep goes on (its worker's job ended, a
                    # worker's set-up): asked again, on whichever worker takes it.
                    pending.add(submit(run_id))
                    continue
                record(run_id, row)
            if finished:
                _write_table(sw, rows)
            running = _running(client, {f.key for f in pending})
            if running or finished:
                waited_alone = time.monotonic()
            elif waited_alone is not None and time.monotonic() - waited_alone > 30 and not _workers(client):
                stream.write("cutsim-sweep: the scheduler has no workers: nothing runs until one joins "
                             "(dask-worker SCHEDULER_ADDRESS --nthreads 1)\n")
                waited_alone = None
            bar.show(*counts(), running)
    except KeyboardInterrupt:
        # Stopped: the runs not finished are "stopped" rows (their cutsim writes a checkpoint
        # as its worker goes: the same command goes on from there).
        for run in sw.runs:
            if run["index"] not in rows:
                rows[run["index"]] = {"status": "stopped", "index": run["index"], "values": run["values"],
                                      "id": run["id"], "error": "the sweep was stopped before this run ended"}
        _write_table(sw, rows)
        raise
    bar.show(*counts(), 0, final=True)
    _write_table(sw, rows)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (matplotlib's missing glyphs and the like)
            _plot(sw, rows)
    except Exception as e:  # the picture is a convenience: its failure is said, the table stays
        stream.write(f"cutsim-sweep: no summary.png: {type(e).__name__}: {e}\n")
    return Rows([_table_row(sw, rows[i]) for i in sorted(rows)], sw.results)


def _workers(client):
    try:
        return len(client.scheduler_info()["workers"])
    except Exception:
        return 1


def prepare(sweep, *, results=None, cutsim_executable=None):
    """Checks a sweep, claims its results folder, writes every run's scene there and
    RESULTS/commands.txt: one `cutsim run RESULTS/runs/ID.scene.json --out RESULTS/runs/ID` a
    line, in the sweep's order, for a batch system's job array. Returns the commands file's path;
    a later sweep() finds the folders those commands finished and only extracts their quantities."""
    from . import InvalidInputError
    try:
        sw = _load_sweep(sweep, results, cutsim_executable, True)
        _claim(sw, _sweep_text(sweep))
    except _Input as e:
        raise InvalidInputError(str(e)) from None
    exe = _find_cutsim(cutsim_executable)
    task = {"checkpoint_every": sw.checkpoint_every}
    lines, seen = [], set()
    for run in sw.runs:
        if run["id"] in seen:
            continue
        seen.add(run["id"])
        p = _paths(sw.results, run["id"])
        _write_scene(p, run)
        # Under the run's lock (as the sweep's own tasks), and nothing done for a finished folder.
        inner = f"test -e {shlex.quote(os.path.join(p['dir'], 'steps.csv'))} || exec " + " ".join(
            shlex.quote(x) for x in _run_command(exe, p, task))
        lines.append(f"flock {shlex.quote(p['lock'])} sh -c {shlex.quote(inner)}")
    path = os.path.join(sw.results, "commands.txt")
    _write_atomic(path, "\n".join(lines) + "\n")
    return path


def _write_scene(p, run):
    if not os.path.exists(p["scene"]):
        _write_atomic(p["scene"], json.dumps(run["scene"], indent=1))


def _sweep_text(sweep_in):
    if isinstance(sweep_in, dict):
        from . import _json
        return _json(sweep_in, "<sweep dict>")
    with open(sweep_in, encoding="utf-8-sig") as f:
        return f.read()


class Rows(list):
    """A sweep's rows (one dict per run), with `results` (its folder), `csv` and `picture`."""

    def __init__(self, rows, results):
        super().__init__(rows)
        self.results = results
        self.csv = os.path.join(results, "results.csv")
        self.picture = os.path.join(results, "summary.png")


def _running(client, keys):
    try:
        processing = client.processing()
        info = client.scheduler_info()["workers"]
    except Exception:
        return 0
    n = 0
    for w, ks in processing.items():
        mine = sum(1 for k in ks if k in keys)
        n += min(mine, info.get(w, {}).get("nthreads", 1))
    return n


def _task(sw, run, exe):
    return {"results": sw.results, "id": run["id"], "index": run["index"], "values": run["values"],
            "version": sw.version, "cutsim": os.path.abspath(exe) if exe else None,
            "checkpoint_every": sw.checkpoint_every,
            "extract": sw.extract, "extract_key": sw.extract_key, "timeout": sw.timeout}


# ---------------------------------------------------------------------------------------------
# The command line: cutsim-sweep
# ---------------------------------------------------------------------------------------------

def main(argv=None):
    import argparse
    ap = argparse.ArgumentParser(
        prog="cutsim-sweep",
        description="Run a parameter sweep of a cutsim scene on Dask (docs/sweeps.md): by default on a local "
                    "cluster of one worker process per core; --scheduler sends it to a running Dask cluster.")
    ap.add_argument("sweep", help="the sweep file (JSON)")
    ap.add_argument("--scheduler", help="a Dask scheduler's address, tcp://HOST:PORT (default: a local cluster)")
    ap.add_argument("--workers", type=int, help="the local cluster's worker processes (default: one per core)")
    ap.add_argument("--results", help="the results folder (default: the sweep's \"results\", or out/sweeps/NAME)")
    ap.add_argument("--retry-failed", action="store_true", help="run again the runs that failed before")
    ap.add_argument("--scheduler-file", help="the scheduler's address from the JSON file dask-scheduler --scheduler-file writes")
    ap.add_argument("--check", action="store_true", help="check the sweep and every run's scene, list the runs, run nothing")
    ap.add_argument("--prepare", action="store_true",
                    help="check, write each run's scene in the results folder and RESULTS/commands.txt (one `cutsim run` a line, "
                         "for a job array), run nothing; a later cutsim-sweep collects the finished folders")
    ap.add_argument("--cutsim", help="the cutsim program the workers run (default: found next to this package or on PATH)")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the scheduler (default 10)")
    a = ap.parse_args(argv)
    from . import InvalidInputError
    try:
        if not a.timeout > 0:
            raise InvalidInputError(f"--timeout: expected a number of seconds > 0, got {a.timeout}")
        if a.workers is not None and a.workers < 1:
            raise InvalidInputError(f"--workers: expected a number >= 1, got {a.workers}")
        if a.scheduler_file:
            if a.scheduler:
                raise InvalidInputError("give --scheduler or --scheduler-file, not both")
            # The scheduler may still be starting (a batch job starts both): wait for its file.
            deadline = time.monotonic() + a.timeout
            while True:
                try:
                    with open(a.scheduler_file, encoding="utf-8") as f:
                        a.scheduler = json.load(f)["address"]
                    if not isinstance(a.scheduler, str):
                        raise TypeError(f"its address is {a.scheduler!r}, not a string")
                    break
                except (OSError, ValueError, KeyError, TypeError) as e:
                    if time.monotonic() > deadline:
                        raise InvalidInputError(f"--scheduler-file {a.scheduler_file}: no scheduler address there "
                                                f"within {a.timeout:g} s ({e})") from None
                    time.sleep(0.2)
        if a.prepare:
            commands = prepare(a.sweep, results=a.results, cutsim_executable=a.cutsim)
            print(f"commands    {commands} (one run a line: cutsim run SCENE --out FOLDER)")
            print(f"then        cutsim-sweep {a.sweep}{' --results ' + a.results if a.results else ''} (collects the finished runs, runs the others)")
            return 0
        if a.check:
            sw = load_sweep(a.sweep, results=a.results, cutsim_executable=a.cutsim)
            try:
                _check_results(sw)
            except _Input as e:
                raise InvalidInputError(str(e)) from None
            print(f"sweep       {sw.name} ({sw.source}): {len(sw.runs)} runs of {sw.scene_path}, results in {sw.results}")
            for run in sw.runs:
                print(f"  run {run['index']:>4}  {run['id']}  {run['label']}")
            return 0
        start = time.monotonic()
        rows = sweep(a.sweep, results=a.results, scheduler=a.scheduler, workers=a.workers, progress=not a.quiet,
                     retry_failed=a.retry_failed, cutsim_executable=a.cutsim, connect_timeout=a.timeout)
    except InvalidInputError as e:
        print(f"cutsim-sweep: {e}", file=sys.stderr)
        return 2
    except FileNotFoundError as e:
        print(f"cutsim-sweep: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cutsim-sweep: stopped; run the same command again to go on (finished runs are kept)", file=sys.stderr)
        return 130
    failed = [r for r in rows if r["status"] == "failed"]
    stopped = [r for r in rows if r["status"] == "stopped"]
    print(f"runs        {len(rows)}: {len(rows) - len(failed) - len(stopped)} done, {len(failed)} failed"
          f"{f', {len(stopped)} stopped (the same command goes on with them)' if stopped else ''} ({time.monotonic() - start:.1f} s)")
    print(f"results     {rows.csv}")
    print(f"picture     {rows.picture}")
    print(f"run folders {os.path.join(rows.results, 'runs', 'ID')} (the folder column; cutsim view FOLDER plays one)")
    for r in failed[:10]:
        print(f"failed      run {r['run']}: {r['error']}", file=sys.stderr)
    if len(failed) > 10:
        print(f"failed      ... and {len(failed) - 10} more (results.csv)", file=sys.stderr)
    return 1 if failed or stopped else 0


if __name__ == "__main__":  # python3 -m cutsim.sweeps: the tasks must name cutsim.sweeps, not __main__
    from cutsim.sweeps import main as _main
    sys.exit(_main())
