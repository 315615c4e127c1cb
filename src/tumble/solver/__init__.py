"""Solvers of the Simulator's contact step (issues 3 and 4): Box2D v3's soft step.

``contact``: the contact stages over contact arrays (``ContactSolver``, ``SoftStepSettings``;
their kernels in ``contact_solve``); ``partition``: the sweeps' slabs on both cores;
``soft_step``: the step that runs them with integration and joints (``SoftStep``, used by
``Simulator.step``); ``joints``: the joint solver (``joint_math``, ``joint_solve``,
``joint_tree``, ``joint_stepper``); ``island``: islands and sleeping.
"""

from .contact import (
    RESTITUTION_THRESHOLD,
    ContactSolver,
    SoftStepSettings,
    soft_coefficients,
)

__all__ = ["RESTITUTION_THRESHOLD", "ContactSolver", "SoftStepSettings", "soft_coefficients"]
