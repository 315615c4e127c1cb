"""``Material``: a body's surface for contact, Coulomb friction and restitution (how two bodies'
materials combine: docs/contact.md, ``solver.contact``). Its companion, which bodies touch at
all, is ``collision.filter.CollisionFilter``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from .errors import InputError


@dataclass(frozen=True)
class Material:
    """Surface material: Coulomb ``friction`` coefficient (>= 0) and ``restitution`` (0..1)."""

    friction: float = 0.5
    restitution: float = 0.0

    def __post_init__(self):
        f = float(self.friction)
        e = float(self.restitution)
        if not math.isfinite(f) or f < 0:
            raise InputError(f"must be a finite number >= 0, got {self.friction}", "friction")
        if not math.isfinite(e) or not 0.0 <= e <= 1.0:
            raise InputError(f"must be between 0 and 1, got {self.restitution}", "restitution")
        object.__setattr__(self, "friction", f)
        object.__setattr__(self, "restitution", e)

    @classmethod
    def coerce(cls, value) -> "Material":
        if value is None:
            return cls()
        if isinstance(value, Material):
            return value
        if isinstance(value, Mapping):
            unknown = set(value) - {"friction", "restitution"}
            if unknown:
                raise InputError(f"unknown key {sorted(unknown)[0]!r} (expected friction, restitution)", "material")
            return cls(**value)
        raise InputError(f"expected a Material or a mapping, got {value!r}", "material")
