"""Contact solver (issue 3, deliverable 4): Box2D v3's soft step over contact arrays.

Not yet wired into the Simulator; ``step_with_contacts`` is a standalone stepper for tests.
"""

from .contact import (
    RESTITUTION_THRESHOLD,
    ContactSolver,
    SoftStepSettings,
    soft_coefficients,
    step_with_contacts,
)

__all__ = ["RESTITUTION_THRESHOLD", "ContactSolver", "SoftStepSettings", "soft_coefficients", "step_with_contacts"]
