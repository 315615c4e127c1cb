"""Scene files: the typed values of an entry, read with one-line errors.

``ValueReader`` reads one value at a key (a table with its allowed keys, a number, a
positive or non-negative one, a whole number, a boolean, a string among choices, a vector, rows
of numbers, a body name) and raises ``InputError`` ``FILE: KEY: problem`` when it is not what
the key needs. ``where`` is the key being read, so that an unexpected exception further on is
still reported at its key (``scene.parse_scene``). ``tumble.scene`` parses the document with
it; ``scene_joints`` shares its wording (``_describe``).
"""

from __future__ import annotations

import math
from pathlib import Path

from .errors import InputError


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _describe(value) -> str:
    """How a value of the wrong type is shown in a message."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    if isinstance(value, str):
        shown = value if len(value) <= 40 else value[:37] + "..."
        return f"{shown!r} (a string)"
    if isinstance(value, int) and _digits(value) > 30:
        return f"an integer of {_digits(value)} digits"
    if isinstance(value, (int, float)):
        return f"{value!r} (a number)"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    return f"{value!r} ({type(value).__name__})"


# NOTE: whole numbers of a scene (counts, seeds, substeps) go to NumPy and compiled code as
# 64-bit integers: a larger one overflowed there with a traceback (10**30 substeps)
MAX_WHOLE = 2**63 - 1


def _digits(value: int) -> int:
    """Decimal digits of ``abs(value)`` (about; without ``str``, which refuses more than 4300)."""
    return max(1, int(abs(value).bit_length() * 0.30103) + 1)


def shown(value) -> str:
    """A value as a message shows it: its repr on one line, at most 60 characters, and a whole
    number beyond ``MAX_WHOLE`` by its digits (``repr`` refuses one of more than 4300)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_WHOLE:
        return f"an integer of {_digits(value)} digits"
    text = " ".join(repr(value).split())
    return text if len(text) <= 60 else text[:57] + "..."


def _int_digits_problem(exc: ValueError) -> str:
    """The problem of a ValueError raised while reading a document's text: Python's limit on an
    integer's digits (``sys.set_int_max_str_digits``) said plainly, else the error's own text."""
    text = _one_line(str(exc))
    if "integer string conversion" in text:
        return "an integer of more than 4300 digits (write a number that large as a float, e.g. 1e5000)"
    return text


def _fmt(v: float) -> str:
    return f"{v:g}"


class ValueReader:
    """Typed values of one document at their keys. ``where`` is the key being read."""

    def __init__(self, file: str | None, base_dir: Path):
        self.file = file
        self.base_dir = base_dir
        self.where = ""

    # ----------------------------------------------------------------- errors
    def error(self, problem: str, key: str | None) -> InputError:
        return InputError(problem, key or None, self.file)

    def library(self, key: str, call, *args, **kwargs):
        """Call a library constructor; its InputErrors (keys relative to its arguments) get ``key`` in front."""
        self.where = key
        try:
            return call(*args, **kwargs)
        except InputError as err:
            raise err.within(key, self.file) from None

    # ----------------------------------------------------------------- typed values
    def table(self, value, key: str, allowed, required=(), what="a table") -> dict:
        self.where = key
        if not isinstance(value, dict):
            raise self.error(f"expected {what}, got {_describe(value)}", key)
        allowed = tuple(allowed)
        for k in value:
            if k not in allowed:
                sub = f"{key}.{k}" if key else str(k)
                raise self.error(f"unknown key (expected one of {', '.join(allowed)})", sub)
        for k in required:
            if k not in value:
                raise self.error(f"missing key {k!r}", key)
        return value

    def number(self, value, key: str) -> float:
        self.where = key
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(f"expected a number, got {_describe(value)}", key)
        try:
            v = float(value)
        except OverflowError:  # a JSON integer beyond the float range
            raise self.error(f"must be a finite number, got an integer of {_digits(value)} digits", key) from None
        if not math.isfinite(v):
            raise self.error(f"must be a finite number, got {v}", key)
        return v

    def positive(self, value, key: str) -> float:
        v = self.number(value, key)
        if v <= 0:
            raise self.error(f"must be positive, got {_fmt(v)}", key)
        return v

    def nonnegative(self, value, key: str) -> float:
        v = self.number(value, key)
        if v < 0:
            raise self.error(f"must be >= 0, got {_fmt(v)}", key)
        return v

    def integer(self, value, key: str, minimum: int) -> int:
        self.where = key
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected a whole number, got {_describe(value)}", key)
        if value < minimum:
            raise self.error(f"must be >= {minimum}, got {value if _digits(value) < 30 else f'an integer of {_digits(value)} digits'}", key)
        if value > MAX_WHOLE:
            raise self.error(f"must be at most 2^63 - 1, got an integer of {_digits(value)} digits", key)
        return value

    def boolean(self, value, key: str) -> bool:
        self.where = key
        if not isinstance(value, bool):
            raise self.error(f"expected true or false, got {_describe(value)}", key)
        return value

    def string(self, value, key: str, choices=None) -> str:
        self.where = key
        if not isinstance(value, str):
            raise self.error(f"expected a string, got {_describe(value)}", key)
        if choices is not None and value not in choices:
            raise self.error(f"must be one of {', '.join(repr(c) for c in choices)}, got {value!r}", key)
        return value

    def vector(self, value, key: str, length: int = 3, check=None) -> list[float]:
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of {length} numbers, got {_describe(value)}", key)
        if len(value) != length:
            raise self.error(f"expected a list of {length} numbers, got {len(value)}", key)
        check = check or self.number
        return [check(x, f"{key}[{i}]") for i, x in enumerate(value)]

    def rows(self, value, key: str, width: int, item=None, min_rows: int = 1) -> list[list]:
        """A list of rows of ``width`` numbers (points, vertices, faces)."""
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of rows of {width} numbers, got {_describe(value)}", key)
        if len(value) < min_rows:
            raise self.error(f"expected at least {min_rows} rows, got {len(value)}", key)
        return [self.vector(row, f"{key}[{i}]", width, item) for i, row in enumerate(value)]

    def name_list(self, value, key: str, names: dict) -> list[str]:
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of body names, got {_describe(value)}", key)
        return [self.body_ref(v, f"{key}[{i}]", names) for i, v in enumerate(value)]

    def body_ref(self, value, key: str, names: dict) -> str:
        name = self.string(value, key)
        if name not in names:
            raise self.error(f"unknown body {name!r}", key)
        return name
