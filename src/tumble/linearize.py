"""A robot's step linearized by finite differences: MuJoCo's ``mjd_transitionFD``.

A controller designer (LQR, iLQR, MPC) wants the step as a linear map about the present state:
with x = (qpos, qvel) in joint coordinates (``kinematics``: MuJoCo's layout) and u the inputs,

    dx' = A dx + B du,    A (2 nv, 2 nv), B (2 nv, nu),

where dx is a small change of the state in the tangent space (positions by ``Kinematics.
integrate``'s rates, so a ball's or a free joint's 4 quaternion numbers count as 3 rates, as
MuJoCo's ``mj_differentiatePos``) and dx' the change it makes one step later. tumble's step has
no derivative of its own (contacts, limits and the joint solver's iterations are not smooth), so
the Jacobians are taken the way MuJoCo takes them: each column by stepping the simulation once
from the state moved by ``eps`` along one coordinate (both ways, ``centered``), every run
restored from one snapshot (``Simulator.save_state``) so that the warm starts, contacts and
sleep are the same in each. The simulation is left exactly as it was: the next step gives the
bits it would have given without the call.

Inputs u: an MJCF model's actuators (MuJoCo's ``ctrl``, in the file's order; ``Robot.
set_controls``), or the applied torques and forces of the robot's hinges and sliders
(``Robot.set_joint_torque``, PyBullet's ``TORQUE_CONTROL``): ``inputs="controls"`` or
``"torques"`` (default: the controls when the robot has actuators). A control at an end of its
``ctrlrange`` is differenced on the inside only (a step past it would be clipped back).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .kinematics import ONE_DOF, _quat_mul

DEFAULT_EPS = 1e-6


@dataclass
class Linearization:
    """The step as a linear map about a state (``Kinematics.transition_jacobians``).

    Attributes:
        A: (2 nv, 2 nv) d(qpos', qvel') / d(qpos, qvel), positions in the tangent space (rates).
        B: (2 nv, nu) d(qpos', qvel') / du.
        qpos: (nq,) and qvel: (nv,) the state linearized about (the present one).
        inputs: the names of u's entries (actuators, or joints for torques).
        dt: s, the step.
    """

    A: np.ndarray
    B: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    inputs: list
    dt: float


def quat_log(q) -> np.ndarray:
    """(3,) the rotation vector (rad) of the unit quaternion q (4,), the short way round."""
    w, v = float(q[0]), np.asarray(q[1:], dtype=float)
    if w < 0.0:
        w, v = -w, -v
    s = math.sqrt(float(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
    if s < 1e-300:
        return np.zeros(3)
    return v * (2.0 * math.atan2(s, w) / s)


def difference(kin, qpos1, qpos0, h: float = 1.0) -> np.ndarray:
    """(nv,) the rates that take ``qpos0`` to ``qpos1`` in ``h`` s (MuJoCo's ``mj_differentiatePos``;
    the inverse of ``Kinematics.integrate``): hinges and sliders by their difference, a ball's and
    a free joint's rotation by the log of q0^-1 q1 (the child's frame), a free joint's origin by
    its difference (world)."""
    q1 = kin._check(qpos1, kin.nq, "qpos1")
    q0 = kin._check(qpos0, kin.nq, "qpos0")
    out = np.zeros(kin.nv)
    for c in kin.coordinates:
        a, b, r = q1[c.qpos], q0[c.qpos], out[c.qvel]
        if c.kind in ONE_DOF:
            r[0] = (a[0] - b[0]) / h
        elif c.kind == "spherical":
            r[:] = quat_log(_quat_mul(b * np.array([1.0, -1.0, -1.0, -1.0]), a)) / h
        else:
            r[0:3] = (a[0:3] - b[0:3]) / h
            r[3:6] = quat_log(_quat_mul(b[3:7] * np.array([1.0, -1.0, -1.0, -1.0]), a[3:7])) / h
    return out


def _step_difference(kin, qa, qb) -> np.ndarray:
    """``difference(kin, qa, qb)`` of two positions a step apart from nearly one state, a hinge's part
    taken in (-pi, pi]: its angle is read in (-pi, pi] until the joint solver counts turns (a robot
    put upright, at pi, read -pi + 1e-6 after one perturbed step: a column of 3e6)."""
    d = difference(kin, qa, qb)
    for c in kin.coordinates:
        if c.kind in ("revolute", "continuous"):
            d[c.qvel] = math.remainder(float(d[c.qvel][0]), 2.0 * math.pi)
    return d


def _inputs(robot, inputs):
    """(names, read () -> (nu,), write (sim, u (nu,)), ranges [(lo, hi)]) of the chosen inputs."""
    from .joints import P_EFFORT

    if inputs is None:
        inputs = "controls" if robot.actuators else "torques"
    if inputs == "controls":
        if not robot.actuators:
            raise InputError(f"robot {robot.name!r} has no actuators (an MJCF model's <actuator>); "
                             "use inputs=\"torques\"", "inputs")
        names = list(robot.actuators)
        ranges = [robot.actuators[n].ctrlrange or (-math.inf, math.inf) for n in names]

        def read():
            return np.array([robot.actuators[n].ctrl for n in names], dtype=float)

        def write(sim, u):
            robot.set_controls(sim, {n: float(x) for n, x in zip(names, u)})

        return names, read, write, ranges
    if inputs == "torques":
        kin = robot.kinematics
        names = [c.name for c in kin.coordinates if c.kind in ONE_DOF]
        records = [robot.joints[n] for n in names]

        def read():
            return np.array([r.bound.param[P_EFFORT] for r in records], dtype=float)

        def write(sim, u):
            for n, x in zip(names, u):
                robot.set_joint_torque(sim, n, float(x))

        return names, read, write, [(-math.inf, math.inf)] * len(names)
    raise InputError(f"expected \"controls\" or \"torques\", got {inputs!r}", "inputs")


def transition_jacobians(kin, sim, eps: float = DEFAULT_EPS, centered: bool = True, inputs=None) -> Linearization:
    """``Kinematics.transition_jacobians``: the module docstring."""
    if not (isinstance(eps, (int, float)) and not isinstance(eps, bool) and 0.0 < eps < 1.0):
        raise InputError(f"must be a number in (0, 1), got {eps!r}", "eps")
    if sim.world is not kin.world:
        raise InputError("the simulator steps another world than the robot's", "sim")
    robot = kin.robot
    names, read, write, ranges = _inputs(robot, inputs)
    nv = kin.nv
    qpos0, qvel0 = kin.qpos(sim), kin.qvel()
    u0 = read()
    saved = sim.save_state()

    def step_from(dq, dv, du):
        """(tangent position change, rate change) one step after the state moved by dq, dv and the
        inputs by du, against the unmoved state's."""
        sim.restore_state(saved)
        kin.set_state(kin.integrate(qpos0, dq), qvel0 + dv, sim=sim)
        write(sim, u0 + du)
        sim.step(1)
        return kin.qpos(sim), kin.qvel()

    try:
        q_ref, v_ref = step_from(np.zeros(nv), np.zeros(nv), np.zeros(len(names)))

        def column(dq, dv, du, plus, minus):
            """One column: the centred difference, or one-sided where the input may not go."""
            qa, va = step_from(dq * plus, dv * plus, du * plus) if plus else (q_ref, v_ref)
            qb, vb = step_from(-dq * minus, -dv * minus, -du * minus) if minus else (q_ref, v_ref)
            span = eps * (plus + minus)
            return np.concatenate([_step_difference(kin, qa, qb) / span, (va - vb) / span])

        A = np.empty((2 * nv, 2 * nv))
        B = np.empty((2 * nv, len(names)))
        zero_v, zero_u = np.zeros(nv), np.zeros(len(names))
        back = 1.0 if centered else 0.0
        for i in range(nv):
            e = np.zeros(nv)
            e[i] = eps
            A[:, i] = column(e, zero_v, zero_u, 1.0, back)
            A[:, nv + i] = column(zero_v, e, zero_u, 1.0, back)
        for k, (lo, hi) in enumerate(ranges):
            e = np.zeros(len(names))
            e[k] = eps
            plus = 1.0 if u0[k] + eps <= hi else 0.0
            minus = back if u0[k] - eps >= lo else 0.0
            if plus == 0.0 and minus == 0.0:
                minus = 1.0  # at the upper end: backwards
            B[:, k] = column(zero_v, zero_v, e, plus, minus)
    finally:
        sim.restore_state(saved)
        write(sim, u0)
    return Linearization(A=A, B=B, qpos=qpos0, qvel=qvel0, inputs=names, dt=sim.dt)
