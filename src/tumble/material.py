"""``Material``: a body's surface for contact, Coulomb friction and restitution (how two bodies'
materials combine: docs/contact.md, ``solver.contact``). Its companion, which bodies touch at
all, is ``collision.filter.CollisionFilter``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError, coerce_record


MATERIAL_KEYS = ("friction", "restitution", "rolling_resistance", "spinning_friction")


@dataclass(frozen=True)
class Material:
    """Surface material of a body.

    Args:
        friction: Coulomb coefficient (>= 0); per contact sqrt(fa fb).
        restitution: 0..1; per contact max(ea, eb).
        rolling_resistance: dimensionless (>= 0, Box2D/Box3D's): a round surface (sphere,
            capsule, the side of a cylinder or cone) rolling on another is braked by a torque of
            at most ``rolling_resistance * r * N`` (r its radius, N the normal force); per
            contact max(ca, cb). 0 (the default): balls roll on for ever, as rigid bodies do.
        spinning_friction: m (>= 0, MuJoCo's torsional friction): a torque of at most
            ``spinning_friction * N`` against turning about the contact normal (a ball or a top
            spinning in place); per contact max(sa, sb).
    """

    friction: float = 0.5
    restitution: float = 0.0
    rolling_resistance: float = 0.0
    spinning_friction: float = 0.0

    def __post_init__(self):
        for key in MATERIAL_KEYS:
            raw = getattr(self, key)
            if isinstance(raw, bool):
                raise InputError(f"expected a number, got {raw}", key)
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise InputError(f"expected a number, got {raw!r}", key) from None
            if key == "restitution":
                if not math.isfinite(value) or not 0.0 <= value <= 1.0:
                    raise InputError(f"must be between 0 and 1, got {raw}", key)
            elif not math.isfinite(value) or value < 0:
                raise InputError(f"must be a finite number >= 0, got {raw}", key)
            object.__setattr__(self, key, value)

    @property
    def resists_rolling(self) -> bool:
        """Whether contacts of this material need the rolling and spinning rows
        (``solver.contact_rolling``)."""
        return self.rolling_resistance > 0.0 or self.spinning_friction > 0.0

    def to_dict(self) -> dict:
        return {key: getattr(self, key) for key in MATERIAL_KEYS}

    @classmethod
    def coerce(cls, value) -> "Material":
        """None (the default material), a ``Material``, or a mapping with its keys."""
        return coerce_record(cls, value, MATERIAL_KEYS, "material")
