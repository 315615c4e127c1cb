"""``Material``: a body's surface for contact, Coulomb friction and restitution (how two bodies'
materials combine: docs/contact.md, ``solver.contact``). Its companion, which bodies touch at
all, is ``collision.filter.CollisionFilter``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError, coerce_record


MATERIAL_KEYS = ("friction", "restitution", "rolling_resistance", "spinning_friction", "margin",
                 "friction_combine", "restitution_combine", "condim")
NUMBER_KEYS = MATERIAL_KEYS[:5]
#: how two bodies' frictions or restitutions make a contact's, in the order of precedence of
#: PhysX's ``PxCombineMode`` (a pair takes the later of its two bodies' modes), after tumble's own
#: "geometric" (Box2D's sqrt(a b)): MuJoCo's frictions combine by "max", Bullet's by "multiply",
#: PhysX's by "average" by default
COMBINE_MODES = ("geometric", "average", "min", "multiply", "max")
COMBINE_UNSET = -1  # a body that sets no mode: the pair's is the other's, else the default
FRICTION_DEFAULT_MODE = COMBINE_MODES.index("geometric")
RESTITUTION_DEFAULT_MODE = COMBINE_MODES.index("max")
#: MuJoCo's contact dimensions (``Material.condim``); a body without one counts as the largest
CONDIMS = (1, 3, 4, 6)


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
        margin: m (>= 0, MuJoCo's geom ``margin``, PhysX's rest offset): two bodies come to rest
            this much further apart, the sum of their margins (MuJoCo sums a pair's margins:
            measured, MuJoCo 3 and 4); their contacts start that much earlier. 0: surfaces
            touch.
        friction_combine, restitution_combine: None (the default) or one of ``COMBINE_MODES``:
            how a contact's friction (restitution) is made from its two bodies' (PhysX's combine
            modes): "geometric" sqrt(a b), "average" (a + b) / 2, "min", "multiply" a b, "max".
            A pair takes the mode later in that list of its two bodies' (PhysX's precedence); a
            body without one defers to the other; neither: "geometric" for friction (Box2D's),
            "max" for restitution. MuJoCo models load with "max" friction (MuJoCo's rule).
        condim: None (the default: every term its coefficients give) or MuJoCo's contact
            dimensions, 1, 3, 4 or 6; a pair takes the larger of its two bodies' (MuJoCo's rule;
            None counts as 6): 1 a frictionless contact (no sliding, spinning or rolling
            friction), 3 sliding friction only, 4 and spinning friction, 6 and rolling
            resistance. MuJoCo models load with their geoms' ``condim``.
    """

    friction: float = 0.5
    restitution: float = 0.0
    rolling_resistance: float = 0.0
    spinning_friction: float = 0.0
    margin: float = 0.0
    friction_combine: str | None = None
    restitution_combine: str | None = None
    condim: int | None = None

    def __post_init__(self):
        if self.condim is not None:
            if isinstance(self.condim, bool) or self.condim not in CONDIMS:
                raise InputError(f"expected one of 1, 3, 4, 6, got {self.condim!r}", "condim")
            object.__setattr__(self, "condim", int(self.condim))
        for key in ("friction_combine", "restitution_combine"):
            mode = getattr(self, key)
            if mode is not None and (not isinstance(mode, str) or mode not in COMBINE_MODES):
                raise InputError(f"expected one of {', '.join(COMBINE_MODES)}, got {mode!r}", key)
        for key in NUMBER_KEYS:
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

    def combine_codes(self) -> tuple[int, int, int]:
        """(friction mode, restitution mode, condim): the modes as indices of ``COMBINE_MODES``
        (``COMBINE_UNSET``: none), the condim 6 when not set (``contact_solve.combine_material``)."""
        return tuple(COMBINE_UNSET if m is None else COMBINE_MODES.index(m)
                     for m in (self.friction_combine, self.restitution_combine)) + (
            6 if self.condim is None else self.condim,)

    def to_dict(self) -> dict:
        """Its keys, but those of the margin and combine modes only when set (a scene or checkpoint
        written without them reads as before)."""
        out = {key: getattr(self, key) for key in NUMBER_KEYS[:4]}
        if self.margin:
            out["margin"] = self.margin
        for key in ("friction_combine", "restitution_combine", "condim"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out

    @classmethod
    def coerce(cls, value) -> "Material":
        """None (the default material), a ``Material``, or a mapping with its keys."""
        return coerce_record(cls, value, MATERIAL_KEYS, "material")
