"""Sweep specifications: key paths into a scene document, value specs, and the design (grid or random).

Key paths name one value of the scene file::

    bodies.box.mass                    body "box" (by name), key mass
    bodies.box.angular_velocity[1]     one component of a vector
    bodies[0].mass                     a body by position
    robots.arm.joint_positions.elbow   a [[robots]] entry (by its name key, or robots[0]), one joint
    simulation.dt
    forces[0].linear

Specs::

    [a, b, c]              a list (numbers, or bare words such as rk4)
    linspace(a, b, n)      n values from a to b, both included
    range(a, b, step)      a, a + step, ... below b (a + i * step, no accumulated rounding)
    uniform(a, b)          random (only with samples = N)
    normal(mu, sigma)      random (only with samples = N)
    a                      one value

Several keys make a full grid (the first key varies slowest); with ``samples``
each distribution is drawn N times from ``numpy.random.default_rng(seed)`` in
the order the keys are given, and each list or range is drawn uniformly from
its values. Every problem is an ``InputError`` naming the key and the spec.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

# Keys a table of each kind may take (from the scene format; read here, never changed).
from ..scene import BODY_KEYS, FORCE_KEYS, SIMULATION_KEYS
from ..scene_values import MAX_WHOLE, _digits, shown

_TOKEN = re.compile(r"\s*(?:([A-Za-z_][A-Za-z0-9_\-]*)|\[\s*(-?\d+)\s*\])\s*")


# ---------------------------------------------------------------------- key paths


def parse_key(key: str) -> list:
    """``"bodies.box.angular_velocity[1]"`` -> ``["bodies", "box", "angular_velocity", 1]``."""
    if not isinstance(key, str) or not key.strip():
        raise InputError("empty key path (expected e.g. bodies.box.mass)", "--vary")
    parts: list = []
    for n, segment in enumerate(key.strip().split(".")):
        pos = 0
        first = True
        while pos < len(segment):
            m = _TOKEN.match(segment, pos)
            if not m or m.end() == pos:
                raise InputError(f"bad key path {key!r} (expected names and [index] parts, e.g. bodies.box.angular_velocity[1])", "--vary")
            name, index = m.group(1), m.group(2)
            if name is not None:
                if not first:
                    raise InputError(f"bad key path {key!r} (a name must follow a dot)", "--vary")
                parts.append(name)
            else:
                if first and n > 0:
                    raise InputError(f"bad key path {key!r} (an [index] must follow a name)", "--vary")
                parts.append(int(index))
            first = False
            pos = m.end()
        if first:
            raise InputError(f"bad key path {key!r} (empty part)", "--vary")
    return parts


def format_key(parts: list) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def resolve_key(data: dict, key: str) -> list:
    """Check ``key`` against the scene document and return its canonical path (list indices, not names).

    Bodies named in the path are looked up by name; the leaf must be a value that
    exists in the document or a key the scene format knows for that table; an
    ``[i]`` must index an existing list.
    """
    parts = parse_key(key)
    where = f"--vary {key}"
    top = parts[0]
    if top not in ("simulation", "bodies", "forces", "robots"):
        raise InputError(f"unknown key path {key!r} (must start with simulation, bodies, robots or forces)", where)
    path: list = [top]
    node = data.get(top)
    i = 1
    if top == "simulation":
        allowed = SIMULATION_KEYS
        node = node if isinstance(node, dict) else {}
    else:
        if not isinstance(node, list) or not node:
            raise InputError(f"unknown key path {key!r}: the scene has no [[{top}]]", where)
        if len(parts) < 2:
            raise InputError(f"key path {key!r} must name one of the {top} (e.g. {top}[0] or {top}.NAME)", where)
        sel = parts[1]
        if isinstance(sel, int):
            if not 0 <= sel < len(node):
                raise InputError(f"unknown key path {key!r}: {top}[{sel}] does not exist (the scene has {len(node)})", where)
            index = sel
        else:
            names = [b.get("name") if isinstance(b, dict) else None for b in node]
            if top == "forces" or sel not in names:
                known = "(forces are referred to by index)" if top == "forces" else \
                    ", ".join(repr(n) for n in names if isinstance(n, str)) or "(none has a name key: use an index)"
                what = {"bodies": "body", "forces": "force", "robots": "robot"}[top]
                raise InputError(f"unknown key path {key!r}: no {what} named {sel!r} (known: {known})", where)
            index = names.index(sel)
        path.append(index)
        node = node[index]
        i = 2
        if not isinstance(node, dict):
            raise InputError(f"unknown key path {key!r}: {format_key(path)} is not a table", where)
        if top == "bodies":
            allowed = BODY_KEYS
        elif top == "robots":
            from ..scene_robots import ROBOT_KEYS

            allowed = ROBOT_KEYS
        else:
            kind = node.get("type")
            req, opt = FORCE_KEYS.get(kind, ((), ()))
            allowed = ("type",) + tuple(req) + tuple(opt)
    if i >= len(parts):
        raise InputError(f"key path {key!r} names a whole table: name one value in it", where)
    leaf_table_key = parts[i]
    if isinstance(leaf_table_key, int):
        raise InputError(f"bad key path {key!r}: expected a key name after {format_key(path)}", where)
    # walk the rest through the document
    for j, p in enumerate(parts[i:]):
        if isinstance(p, int):
            if not isinstance(node, list):
                raise InputError(f"unknown key path {key!r}: {format_key(path)} is not a list", where)
            if not 0 <= p < len(node):
                raise InputError(f"unknown key path {key!r}: {format_key(path)} has {len(node)} items, no [{p}]", where)
            path.append(p)
            node = node[p]
        else:
            if not isinstance(node, dict):
                raise InputError(f"unknown key path {key!r}: {format_key(path)} is not a table", where)
            if p not in node:
                last = j == len(parts[i:]) - 1
                if j == 0 and last and p in allowed:
                    path.append(p)
                    node = None
                    continue
                raise InputError(f"unknown key path {key!r}: {format_key(path + [p])} is not in the scene"
                                 + (f" (known keys here: {', '.join(allowed)})" if j == 0 else ""), where)
            path.append(p)
            node = node[p]
    if isinstance(node, (dict, list)):
        raise InputError(f"key path {key!r} names a {'table' if isinstance(node, dict) else 'list'}: name one value (e.g. {key}[0])", where)
    return path


def set_path(data: dict, path: list, value):
    """Set the value at a canonical path (from ``resolve_key``) in ``data`` (in place).

    A whole float (2.0) replacing an integer of the document (substeps = 1) is set as an int.
    """
    node = data
    for p in path[:-1]:
        node = node.setdefault(p, {}) if isinstance(node, dict) and isinstance(p, str) else node[p]
    old = node.get(path[-1]) if isinstance(node, dict) else node[path[-1]]
    if (isinstance(old, int) and not isinstance(old, bool) and isinstance(value, float) and value.is_integer()):
        value = int(value)
    node[path[-1]] = value


# ---------------------------------------------------------------------- value specs


@dataclass(frozen=True)
class Spec:
    """One key's values: ``kind`` list | uniform | normal; ``values`` for lists, ``args`` for distributions."""

    key: str
    text: str
    kind: str
    values: tuple = ()
    args: tuple = ()

    @property
    def random(self) -> bool:
        return self.kind in ("uniform", "normal")


_CALL = re.compile(r"^\s*([a-z]+)\s*\((.*)\)\s*$", re.DOTALL)


def _number(text: str, key: str, spec: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"bad spec {spec!r}: {text.strip()!r} is not a number", f"--vary {key}") from None
    if not math.isfinite(v):
        raise InputError(f"bad spec {spec!r}: {text.strip()!r} is not a finite number", f"--vary {key}")
    return v


def _whole(v: int, key: str, spec) -> int:
    # NOTE: a swept whole number goes to the results table (a Parquet int64 column) and to the
    # scene (counts, seeds: 64-bit in NumPy and compiled code); a larger one overflowed there
    if abs(v) > MAX_WHOLE:
        digits = _digits(v)
        raise InputError(f"bad spec {_shown(spec)}: a whole number of {digits} digits is beyond 2^63 - 1 "
                         "(write a value that large as a float, e.g. 1e30)", f"--vary {key}")
    return v


def _shown(spec) -> str:
    """A spec as shown in a message: its text (at most 60 characters), never a 4300-digit number."""
    if isinstance(spec, list):
        text = "[" + ", ".join(_shown(v) for v in spec) + "]"
    elif isinstance(spec, int) and not isinstance(spec, bool) and abs(spec) > MAX_WHOLE:
        text = f"<{shown(spec)}>"
    else:
        text = spec if isinstance(spec, str) else repr(spec)
    text = text if len(text) <= 60 else text[:57] + "..."
    return repr(text) if isinstance(spec, str) else text


def _item(text: str, key: str, spec: str):
    t = text.strip()
    if not t:
        raise InputError(f"bad spec {spec!r}: empty list item", f"--vary {key}")
    if (t[0] == t[-1]) and t[0] in "\"'" and len(t) >= 2:
        return t[1:-1]
    if re.fullmatch(r"[+-]?\d+", t):
        if len(t.lstrip("+-")) > 19:  # beyond 2^63 (and int() of more than 4300 digits is a ValueError)
            raise InputError(f"bad spec {_shown(spec)}: a whole number of {len(t.lstrip('+-'))} digits is beyond 2^63 - 1 "
                             "(write a value that large as a float, e.g. 1e30)", f"--vary {key}")
        return _whole(int(t), key, spec)
    try:
        v = float(t)
    except ValueError:
        if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_\-]*", t) and t.lower() not in ("nan", "inf", "infinity"):
            return t  # a bare word: integrator names and the like
        raise InputError(f"bad spec {spec!r}: {t!r} is neither a number nor a word", f"--vary {key}") from None
    if not math.isfinite(v):
        raise InputError(f"bad spec {spec!r}: {t!r} is not a finite number", f"--vary {key}")
    return v


def parse_spec(key: str, spec) -> Spec:
    """A value spec (text, or from a [sweep] table a number, string or list) -> ``Spec``."""
    where = f"--vary {key}"
    if isinstance(spec, bool):
        raise InputError(f"bad spec {spec!r} (expected a list, linspace(a,b,n), range(a,b,step), uniform(a,b), normal(mu,sigma) or a value)", where)
    if isinstance(spec, (int, float)):
        if isinstance(spec, float) and not math.isfinite(spec):
            raise InputError(f"bad spec {spec!r}: not a finite number", where)
        if isinstance(spec, int):
            _whole(spec, key, spec)
        return Spec(key, repr(spec), "list", (spec,))
    if isinstance(spec, list):
        if not spec:
            raise InputError("bad spec []: an empty list", where)
        vals = []
        for v in spec:
            if isinstance(v, bool) or not isinstance(v, (int, float, str)):
                raise InputError(f"bad spec {_shown(spec)}: list items must be numbers or strings", where)
            if isinstance(v, float) and not math.isfinite(v):
                raise InputError(f"bad spec {_shown(spec)}: {v!r} is not a finite number", where)
            if isinstance(v, int):
                _whole(v, key, spec)
            vals.append(v)
        return Spec(key, json.dumps(spec), "list", tuple(vals))
    if not isinstance(spec, str):
        raise InputError(f"bad spec {spec!r}", where)
    text = spec.strip()
    if not text:
        raise InputError("empty spec (expected e.g. [1,2,3], linspace(0,1,11), uniform(0,1))", where)
    if text.startswith("["):
        if not text.endswith("]"):
            raise InputError(f"bad spec {text!r}: a list must end with ]", where)
        inner = text[1:-1]
        if not inner.strip():
            raise InputError(f"bad spec {text!r}: an empty list", where)
        return Spec(key, text, "list", tuple(_item(t, key, text) for t in inner.split(",")))
    m = _CALL.match(text)
    if m:
        fn, argtext = m.group(1), m.group(2)
        args = [a for a in argtext.split(",")] if argtext.strip() else []
        counts = {"linspace": 3, "range": 3, "uniform": 2, "normal": 2}
        if fn not in counts:
            raise InputError(f"bad spec {text!r}: unknown function {fn!r} (expected linspace, range, uniform or normal)", where)
        if len(args) != counts[fn]:
            raise InputError(f"bad spec {text!r}: {fn} takes {counts[fn]} arguments, got {len(args)}", where)
        nums = [_number(a, key, text) for a in args]
        if fn == "linspace":
            a, b, n = nums
            if n != int(n) or n < 1:
                raise InputError(f"bad spec {text!r}: the count must be a whole number >= 1, got {args[2].strip()}", where)
            n = int(n)
            if n > 10_000_000:
                raise InputError(f"bad spec {text!r}: {n} values is too many", where)
            values = tuple(float(v) for v in np.linspace(a, b, n))
            return Spec(key, text, "list", values)
        if fn == "range":
            a, b, step = nums
            if step == 0 or (b - a) / step <= 0:
                raise InputError(f"bad spec {text!r}: the step must go from {a:g} towards {b:g}", where)
            count = math.ceil((b - a) / step - 1e-9)
            if count > 10_000_000:
                raise InputError(f"bad spec {text!r}: {count} values is too many", where)
            return Spec(key, text, "list", tuple(a + i * step for i in range(count)))
        if fn == "uniform":
            a, b = nums
            if not b > a:
                raise InputError(f"bad spec {text!r}: uniform(a, b) needs a < b", where)
            return Spec(key, text, "uniform", args=(a, b))
        mu, sigma = nums
        if not sigma > 0:
            raise InputError(f"bad spec {text!r}: normal(mu, sigma) needs sigma > 0", where)
        return Spec(key, text, "normal", args=(mu, sigma))
    return Spec(key, text, "list", (_item(text, key, text),))


def parse_vary(item: str) -> tuple[str, str]:
    """``"KEY=SPEC"`` -> (key, spec text)."""
    if not isinstance(item, str) or "=" not in item:
        raise InputError(f"expected KEY=SPEC, got {item!r} (e.g. bodies.box.mass=linspace(1,2,5))", "--vary")
    key, spec = item.split("=", 1)
    key = key.strip()
    if not key:
        raise InputError(f"expected KEY=SPEC, got {item!r}: no key", "--vary")
    return key, spec.strip()


# ---------------------------------------------------------------------- the design


MAX_VARIANTS = 50_000_000


def design(specs: list[Spec], samples: int | None = None, seed: int | None = None) -> dict[str, list]:
    """The variants: {key: [value of variant 0, 1, ...]} (same length for every key).

    Without ``samples``: the full grid of the lists (first key slowest); a
    distribution is an error. With ``samples``: N random variants, at least one
    distribution required.
    """
    if not specs:
        raise InputError("nothing to vary: give at least one --vary KEY=SPEC (or a [sweep] vary table)", "--vary")
    if samples is None:
        rnd = [s for s in specs if s.random]
        if rnd:
            raise InputError(f"{rnd[0].text} is a distribution: random sampling needs --samples N", f"--vary {rnd[0].key}")
        total = 1
        for s in specs:
            total *= len(s.values)
        if total > MAX_VARIANTS:
            raise InputError(f"the grid has {total} variants (more than {MAX_VARIANTS}); use --samples", "--vary")
        cols: dict[str, list] = {s.key: [] for s in specs}
        for combo in itertools.product(*(s.values for s in specs)):
            for s, v in zip(specs, combo):
                cols[s.key].append(v)
        return cols
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise InputError(f"must be a whole number >= 1, got {samples!r}", "--samples")
    if samples > MAX_VARIANTS:
        raise InputError(f"must be at most {MAX_VARIANTS}, got {samples}", "--samples")
    if not any(s.random for s in specs):
        raise InputError("--samples needs at least one distribution (uniform(a,b) or normal(mu,sigma)) among the --vary specs; "
                         "lists and ranges alone make a grid (drop --samples)", "--samples")
    rng = np.random.default_rng(0 if seed is None else seed)
    cols = {}
    for s in specs:
        if s.kind == "uniform":
            cols[s.key] = [float(v) for v in rng.uniform(s.args[0], s.args[1], samples)]
        elif s.kind == "normal":
            cols[s.key] = [float(v) for v in rng.normal(s.args[0], s.args[1], samples)]
        else:
            idx = rng.integers(0, len(s.values), samples)
            cols[s.key] = [s.values[int(k)] for k in idx]
    return cols
