"""Typed exceptions. Each carries the one line that the CLI prints (file, key, problem)."""

from __future__ import annotations

from typing import Mapping


class TumbleError(Exception):
    """Base class of every error tumble raises on purpose."""


class InputError(TumbleError, ValueError):
    """Bad input: a scene file, a keyword argument, a mesh file.

    ``str(err)`` is one line ``"FILE: KEY: PROBLEM"`` (parts that are not known are
    left out). The CLI prints exactly that line and exits with status 2.

    Args:
        problem: what is wrong, e.g. ``"must be positive, got -1.0"``.
        key: key path into the scene, e.g. ``"bodies[1].mass"`` (or the keyword name).
        file: the file the input came from.
    """

    def __init__(self, problem: str, key: str | None = None, file: str | None = None):
        self.problem = problem
        self.key = key
        self.file = file
        super().__init__(self._line())

    def _line(self) -> str:
        parts = [p for p in (self.file, self.key) if p]
        return ": ".join(_printable(str(p)) for p in parts + [self.problem])

    def within(self, key_prefix: str | None = None, file: str | None = None) -> "InputError":
        """The same error, seen from an outer key (``bodies[2]``) or a file. An error already
        keyed by that outer key (a record's own ``coerce``: ``material``) keeps its key."""
        key = self.key
        if key_prefix and key != key_prefix:
            key = f"{key_prefix}.{key}" if key and not key.startswith("[") else f"{key_prefix}{key or ''}"
        return type(self)(self.problem, key, file or self.file)

    def __str__(self) -> str:  # keep the line current if attributes were changed
        return self._line()


def _printable(text: str) -> str:
    """``text`` with control characters escaped (a newline in a key becomes ``\\n``): the line stays one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class TumbleWarning(UserWarning):
    """Something tumble did in place of what was asked, said once (the CLI prints it as a note line):
    a moving concave mesh colliding as its convex hull."""


class SimulationError(TumbleError, RuntimeError):
    """The state of a run went bad (non-finite numbers, a quaternion off unit length)."""


def coerce_record(cls, value, keys, key: str, default=None):
    """``value`` as a record of dataclass ``cls`` (Material, CollisionFilter): None (``default``,
    else ``cls()``), a ``cls``, or a mapping whose keys are among ``keys``; else an InputError
    keyed ``key``."""
    if value is None:
        return cls() if default is None else default
    if isinstance(value, cls):
        return value
    if isinstance(value, Mapping):
        unknown = set(value) - set(keys)
        if unknown:
            raise InputError(f"unknown key {sorted(unknown)[0]!r} (expected {', '.join(keys)})", key)
        return cls(**value)
    raise InputError(f"expected a {cls.__name__} or a mapping, got {value!r}", key)
