"""A robot's kinematics and dynamics in joint coordinates: MuJoCo's ``qpos``/``qvel``, ``mj_jac``,
``mj_fullM``, ``mj_rne``, PyBullet's ``calculateJacobian``, ``calculateMassMatrix``,
``calculateInverseDynamics`` and ``calculateInverseKinematics``.

tumble simulates a robot in maximal coordinates (each link a body with x, R, P, L; the joints
constraints between them). A controller, a planner or a student checking Lagrange's equations
wants the reduced description: the joint coordinates q, their rates, the Jacobian of a link
point, the joint-space inertia M(q), the torques that give an acceleration. ``Kinematics``
(``robot.kinematics``) computes them from the robot's model (``urdf.UrdfModel``: the link
frames, joint origins and axes) and the masses and inertias of its bodies as the world holds
them (links merged by fixed joints and MJCF's virtual links included), at a given q or at the
world's present state.

Coordinates, in MuJoCo's layout and order (the file's joint order, parents before children in
every file tumble reads):

- a hinge (URDF revolute, continuous; MJCF hinge): 1 position (rad), 1 rate (rad/s);
- a slider (URDF prismatic; MJCF slide): 1 (m), 1 (m/s);
- a ball (URDF spherical; MJCF ball): 4 positions, the unit quaternion (w, x, y, z) of the child
  link frame in the joint's zero frame, and 3 rates, the child's angular velocity relative to the
  parent in the child link's frame (MuJoCo's convention);
- a free joint (MJCF free, URDF floating, and a robot's moving base): 7 positions, the link
  frame's origin (m, world) and its orientation quaternion (world), and 6 rates, the origin's
  velocity (m/s, world) then the angular velocity in the link's frame (MuJoCo's; PyBullet gives a
  floating base's angular rates in the world frame and its position at the centre of mass).

Fixed joints that were not merged add no coordinate. The base of a robot that is not fixed
counts as a free joint named after its root link, first.

Jacobians have 6 rows (linear velocity of the point, m/s; angular velocity, rad/s; world frame)
and one column per rate. Inverse dynamics is the rigid-body part: M(q) qdd + c(q, qd) with
gravity, plus each coordinate's armature (MuJoCo adds armature to M's diagonal); joint damping,
springs, friction, limits, contacts and applied efforts are not in it (as PyBullet's
``calculateInverseDynamics`` and MuJoCo's ``mj_rne``).

The recursion is Featherstone's recursive Newton-Euler algorithm (Featherstone, Rigid Body
Dynamics Algorithms, 2008, ch. 5; Craig, Introduction to Robotics, 3rd ed., sec. 6.5), written
with world-frame vectors at the link origins rather than spatial vectors: per link, the angular
velocity and acceleration and the origin's velocity and acceleration going out from the base,
then each body's Newton-Euler force and moment coming back. The mass matrix is summed from the
bodies' Jacobians, M = sum m Jv^T Jv + Jw^T I Jw (an independent route: the tests compare
the two).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from . import kinematics_kernels as KK
from .math3d import matrix_to_quat, quat_to_matrix

ONE_DOF = ("revolute", "continuous", "prismatic")
POSITION_SIZE = {"revolute": 1, "continuous": 1, "prismatic": 1, "spherical": 4, "floating": 7, "fixed": 0}
RATE_SIZE = {"revolute": 1, "continuous": 1, "prismatic": 1, "spherical": 3, "floating": 6, "fixed": 0}


def _unit_quat(q, key):
    q = np.asarray(q, dtype=float)
    n = float(np.linalg.norm(q))
    if not math.isfinite(n) or n < 1e-12:
        raise InputError(f"a quaternion must be finite and non-zero, got {q.tolist()}", key)
    return q / n


def _rotation_angle(R, axis) -> float:
    """The angle (rad, in (-pi, pi]) of a rotation R (3, 3) about a unit axis (3,)."""
    vee = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return math.atan2(float(axis @ vee), 0.5 * (float(np.trace(R)) - 1.0))


def _quat_exp(w, h):
    """The unit quaternion (4,) of the rotation by the vector w (3,) rad/s over h s."""
    speed = float(np.linalg.norm(w))
    if speed * abs(h) < 1e-300:
        return np.array([1.0, 0.0, 0.0, 0.0])
    theta = speed * h  # negative h: the rotation back
    axis = w / speed
    return np.concatenate([[math.cos(0.5 * theta)], math.sin(0.5 * theta) * axis])


def _quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


@dataclass
class Coordinate:
    """One joint's coordinates: ``name`` (the model's joint name, or the root link's for a moving
    base), ``kind`` (``revolute``, ``continuous``, ``prismatic``, ``spherical``, ``floating``),
    ``link`` the child link it moves, ``qpos`` and ``qvel`` the slices of its positions and rates,
    ``armature`` kg m^2 or kg, ``lower``/``upper`` the limits (None: none)."""

    name: str
    kind: str
    link: str
    qpos: slice
    qvel: slice
    armature: float = 0.0
    lower: float | None = None
    upper: float | None = None


@dataclass
class IkSolution:
    """``Kinematics.inverse_kinematics``'s answer: ``qpos`` (nq,) the joint positions found,
    ``position_error`` m and ``angle_error`` rad left at the target, ``iterations``, and
    ``converged`` (both errors under the tolerances)."""

    qpos: np.ndarray
    position_error: float
    angle_error: float
    iterations: int
    converged: bool


class Kinematics:
    """Joint-space kinematics and dynamics of one ``urdf.Robot`` (module docstring); the
    arithmetic in ``kinematics_kernels`` (compiled, on the links as arrays in tree order).

    Attributes:
        coordinates: [``Coordinate``] in qpos order.
        nq, nv: the numbers of positions and rates.
        dof_names: (nv,) a name per rate: the joint's, with ``[k]`` for a ball's or free joint's.
        links: the link names in tree order (the root first, every link after its parent).
    """

    def __init__(self, robot):
        from .urdf import _tree_order

        self.robot = robot
        model = robot.model
        world = robot.world
        self.world = world
        self.order = _tree_order(model)  # the joints, parents first
        self.parent_joint = {j.child: j for j in self.order}
        self.coordinates: list[Coordinate] = []
        nq = nv = 0
        base = robot.links[model.root]
        self.free_base = bool(world.moving[base.index])
        if self.free_base:
            self.coordinates.append(Coordinate(model.root, "floating", model.root, slice(0, 7), slice(0, 6)))
            nq, nv = 7, 6
        for j in model.joints:  # the file's order (MuJoCo's: depth first through the bodies)
            if j.kind not in RATE_SIZE or RATE_SIZE[j.kind] == 0:
                continue
            a, b = POSITION_SIZE[j.kind], RATE_SIZE[j.kind]
            limited = j.kind in ("revolute", "prismatic")
            self.coordinates.append(Coordinate(j.name, j.kind, j.child, slice(nq, nq + a), slice(nv, nv + b),
                                               float(getattr(j, "armature", 0.0)) if b == 1 else 0.0,
                                               j.lower if limited else None, j.upper if limited else None))
            nq, nv = nq + a, nv + b
        self.nq, self.nv = nq, nv
        self.by_link = {c.link: c for c in self.coordinates}
        self.by_name = {c.name: c for c in self.coordinates}
        self.dof_names = []
        for c in self.coordinates:
            size = c.qvel.stop - c.qvel.start
            self.dof_names += [c.name] if size == 1 else [f"{c.name}[{k}]" for k in range(size)]
        self.armature = np.zeros(nv)
        for c in self.coordinates:
            self.armature[c.qvel] = c.armature

        # the links as arrays in tree order (kinematics_kernels' docstring)
        self.links = [model.root] + [j.child for j in self.order]
        index = {link: k for k, link in enumerate(self.links)}
        self.index = index
        L = len(self.links)
        kinds = {"revolute": KK.HINGE, "continuous": KK.HINGE, "prismatic": KK.SLIDE, "spherical": KK.BALL,
                 "floating": KK.FREE, "fixed": KK.FIXED}
        self.parent = np.full(L, -1, dtype=np.int64)
        self.kind = np.zeros(L, dtype=np.int64)
        self.origin_p = np.zeros((L, 3))
        self.origin_R = np.tile(np.eye(3), (L, 1, 1))
        self.axis = np.zeros((L, 3))
        self.qadr = np.full(L, -1, dtype=np.int64)
        self.vadr = np.full(L, -1, dtype=np.int64)
        for k, link in enumerate(self.links):
            c = self.by_link.get(link)
            if c is not None:
                self.qadr[k], self.vadr[k] = c.qpos.start, c.qvel.start
                self.kind[k] = kinds[c.kind]
            j = self.parent_joint.get(link)
            if j is not None:
                self.parent[k] = index[j.parent]
                self.origin_p[k], self.origin_R[k] = j.origin[0], j.origin[1]
                self.axis[k] = j.axis
        # ancestor[l, a]: link a's joint moves link l (a free joint cuts the chain: its link moves
        # by its own rates only)
        self.ancestor = np.zeros((L, L), dtype=np.bool_)
        for k in range(L):
            at = k
            while at >= 0:
                self.ancestor[k, at] = True
                if self.kind[at] == KK.FREE:
                    break
                at = self.parent[at]
        self.dof_link = np.zeros(nv, dtype=np.int64)
        for c in self.coordinates:
            self.dof_link[c.qvel] = index[c.link]
        # each link's body and the link's frame in it; the moving bodies, by their owner link
        self.link_body = np.array([robot.links[link].index for link in self.links], dtype=np.int64)
        self.link_p = np.array([robot.link_frames[link][0] for link in self.links], dtype=float).reshape(L, 3)
        self.link_Rl = np.array([robot.link_frames[link][1] for link in self.links], dtype=float).reshape(L, 3, 3)
        owners = [k for k, link in enumerate(self.links)
                  if robot.owners[link] == link and world.moving[self.link_body[k]]]
        self.body_link = np.array(owners, dtype=np.int64)
        self.body_index = self.link_body[self.body_link]
        # scratch
        self._col_rot = np.zeros(nv, dtype=np.bool_)
        self._col_o = np.zeros((nv, 3))
        self._col_d = np.zeros((nv, 3))

    def couplings(self) -> list:
        """The robot's gears between its 1-D coordinates (URDF's ``<mimic>``, MuJoCo's joint
        equalities: ``Robot.equalities``' ``GearJoint``s), as [(qpos index of the joint that
        follows, qpos index of the one it follows (-1: locked), their qvel indices, coefficients
        (5,) of q = a0 + a1 q_f + ... + a4 q_f^4)], in the order they were added. Inverse
        kinematics keeps them (the mass matrix and the Jacobians do not: each joint is a
        coordinate of its own there, as in MuJoCo)."""
        from .joints import GearJoint

        names = {id(record): name for name, record in self.robot.joints.items()}
        out = []
        for record in self.robot.equalities.values():
            if not isinstance(record, GearJoint):
                continue
            m = self.by_name.get(names.get(id(record.joint)))
            f = None if record.follows is None else self.by_name.get(names.get(id(record.follows)))
            if m is None or m.kind not in ONE_DOF or (record.follows is not None and (f is None or f.kind not in ONE_DOF)):
                continue
            coef = np.zeros(5)
            if record.polynomial is not None:
                given = np.asarray(record.polynomial, dtype=float)
                coef[:len(given)] = given
            else:
                coef[0], coef[1] = record.offset, record.ratio
            out.append((m.qpos.start, -1 if f is None else f.qpos.start, m.qvel.start,
                        -1 if f is None else f.qvel.start, coef))
        return out

    # ------------------------------------------------------------------ frames
    def _check(self, values, size, key):
        v = np.asarray(values, dtype=float)
        if v.shape != (size,) or not np.all(np.isfinite(v)):
            raise InputError(f"expected {size} finite numbers, got shape {v.shape}", key)
        return v

    def _check_qpos(self, qpos):
        q = np.ascontiguousarray(self._check(qpos, self.nq, "qpos"))
        for c in self.coordinates:
            if c.kind in ("spherical", "floating"):
                quat = q[c.qpos][-4:]
                if float(quat @ quat) < 1e-24:
                    raise InputError(f"joint {c.name!r}: a quaternion must be non-zero", "qpos")
        return q

    def _present(self):
        """(o (L, 3), R (L, 3, 3)): the link frames of the world's present state (each link's frame
        in its body, ``Robot.link_pose``, for all links at once)."""
        w = self.world
        b = self.link_body
        Rb = w.R[b]
        origin = w.x[b] - np.einsum("lij,lj->li", Rb, w.com_offset[b])
        return origin + np.einsum("lij,lj->li", Rb, self.link_p), np.einsum("lij,ljk->lik", Rb, self.link_Rl)

    def _frames(self, qpos):
        """(o, R) of every link at ``qpos`` (nq,), or of the present state (None)."""
        if qpos is None:
            return self._present()
        q = self._check_qpos(qpos)
        L = len(self.links)
        o, R = np.empty((L, 3)), np.empty((L, 3, 3))
        if self.free_base:
            root_o, root_R = np.zeros(3), np.eye(3)  # unused: the free joint places the root
        else:
            root_o, root_R = self.robot.link_pose(self.robot.model.root)
        KK.forward_kinematics_kernel(q, np.ascontiguousarray(root_o, dtype=float),
                                     np.ascontiguousarray(root_R, dtype=float), self.parent, self.kind, self.origin_p,
                                     self.origin_R, self.axis, self.qadr, o, R)
        return o, R

    def forward_kinematics(self, qpos=None) -> dict:
        """{link: (origin (3,) m, rotation (3, 3))}, world, of every link at ``qpos`` (nq,;
        default: the present state). A fixed base stays where it is."""
        o, R = self._frames(qpos)
        return {link: (o[k], R[k]) for k, link in enumerate(self.links)}

    def _columns(self, o, R):
        KK.columns_kernel(o, R, self.kind, self.axis, self.vadr, self._col_rot, self._col_o, self._col_d)
        return self._col_rot, self._col_o, self._col_d

    def _bodies(self, o, R):
        """(mass (B,), com (B, 3), I_world (B, 3, 3)) of the moving bodies at the frames."""
        w = self.world
        i = self.body_index
        com, I_world = np.empty((len(i), 3)), np.empty((len(i), 3, 3))
        KK.body_frames_kernel(o, R, self.body_link, self.link_p[self.body_link], self.link_Rl[self.body_link],
                              w.com_offset[i], w.inertia_body[i], com, I_world)
        return np.ascontiguousarray(w.mass[i]), com, I_world

    # ------------------------------------------------------------------ the present state
    def qpos(self, sim=None) -> np.ndarray:
        """(nq,) the joint positions of the world's present state (module docstring), read from the
        bodies' poses. A hinge's angle is taken in (-pi, pi], or, given the ``sim`` that stepped
        the robot, nearest its joint reading (which counts whole turns)."""
        q = np.zeros(self.nq)
        readings = {} if sim is None else {name: s[0] for name, s in self.robot.joint_states(sim).items()}
        o, R = self._present()
        for c in self.coordinates:
            k = self.index[c.link]
            if c.kind == "floating":
                q[c.qpos] = np.concatenate([o[k], matrix_to_quat(np.ascontiguousarray(R[k]))])
                continue
            j = self.parent_joint[c.link]
            P = self.index[j.parent]
            zo, zR = o[P] + R[P] @ j.origin[0], R[P] @ j.origin[1]
            rel_R = zR.T @ R[k]
            if c.kind == "prismatic":
                q[c.qpos] = float(j.axis @ (zR.T @ (o[k] - zo)))
            elif c.kind == "spherical":
                q[c.qpos] = matrix_to_quat(np.ascontiguousarray(rel_R))
            else:
                angle = _rotation_angle(rel_R, j.axis)
                if c.name in readings:
                    angle += 2.0 * math.pi * round((readings[c.name] - angle) / (2.0 * math.pi))
                q[c.qpos] = angle
        return q

    def qvel(self) -> np.ndarray:
        """(nv,) the joint rates of the world's present state, from the bodies' velocities."""
        o, R = self._present()
        bodies = self.robot.links
        w = self.world

        def point_velocity(k, p):  # of link k's body at the world point p, and its angular velocity
            # v + omega x (p - x) written out: np.cross on 3-vectors was a quarter of a linearization's
            # time (``transition_jacobians`` reads qvel once a column)
            i = bodies[self.links[k]].index
            om, v = w.omega[i], w.v[i]
            rx, ry, rz = p[0] - w.x[i, 0], p[1] - w.x[i, 1], p[2] - w.x[i, 2]
            return np.array([v[0] + om[1] * rz - om[2] * ry, v[1] + om[2] * rx - om[0] * rz,
                             v[2] + om[0] * ry - om[1] * rx]), om

        qd = np.zeros(self.nv)
        for c in self.coordinates:
            k = self.index[c.link]
            vC, wC = point_velocity(k, o[k])
            if c.kind == "floating":
                qd[c.qvel] = np.concatenate([vC, R[k].T @ wC])
                continue
            j = self.parent_joint[c.link]
            vP, wP = point_velocity(self.index[j.parent], o[k])
            axis = R[k] @ j.axis
            if c.kind == "prismatic":
                qd[c.qvel] = float(axis @ (vC - vP))
            elif c.kind == "spherical":
                qd[c.qvel] = R[k].T @ (wC - wP)
            else:
                qd[c.qvel] = float(axis @ (wC - wP))
        return qd

    def set_state(self, qpos, qvel=None, sim=None):
        """Put the robot's bodies at ``qpos`` (nq,) moving at ``qvel`` (nv,; default at rest):
        MuJoCo's ``data.qpos[:] = ...; data.qvel[:] = ...``, PyBullet's ``resetBasePositionAndOrientation``,
        ``resetBaseVelocity`` and ``resetJointState`` for every joint at once. Each moving body
        goes to its link's frame and takes the velocity J qvel at its centre of mass (a fixed base
        stays). Takes effect now; with the ``sim`` that steps the world, the joint solver's warm
        start of the robot's joints is cleared (it belonged to the old state) and its hinge
        readings count turns from these angles."""
        q = self._place(qpos, qvel)
        self.world.update_derived()
        self.robot._restart_warm_starts(sim, self.positions(q), None if qvel is None else self.rates(qvel))

    def _place(self, qpos, qvel) -> np.ndarray:
        """``set_state`` but for the world's derived quantities and the joint solver (the caller's:
        ``tumble.envs`` places many copies, then derives once): the checked qpos (nq,)."""
        o, R = self._frames(qpos)
        q = self._check_qpos(qpos)
        qd = np.zeros(self.nv) if qvel is None else np.ascontiguousarray(self._check(qvel, self.nv, "qvel"))
        w = self.world
        _mass, com, _I = self._bodies(o, R)
        cols = self._columns(o, R)
        i = self.body_index
        B = len(i)
        q_b, R_b, P_b, L_b = np.empty((B, 4)), np.empty((B, 3, 3)), np.empty((B, 3)), np.empty((B, 3))
        # PERF: one kernel for the bodies (a loop of 3x3 products here cost 50 us of a 116 us reset
        # of a cart-pole, tumble.envs), and sums in index order: the same bits on every BLAS
        KK.place_bodies_kernel(R, self.body_link, self.link_Rl[self.body_link], com, np.ascontiguousarray(w.mass[i]),
                               np.ascontiguousarray(w.inertia_body[i]), qd, self.ancestor, self.dof_link, *cols,
                               q_b, R_b, P_b, L_b)
        w.q[i], w.R[i], w.x[i], w.P[i], w.L[i] = q_b, R_b, com, P_b, L_b
        w.wake_requests.update(int(k) for k in i)
        return q

    def neutral(self) -> np.ndarray:
        """(nq,) the zero configuration: hinges and sliders at 0, balls at the identity, a free
        joint at the link's present pose."""
        q = np.zeros(self.nq)
        now = None
        for c in self.coordinates:
            if c.kind == "spherical":
                q[c.qpos] = (1.0, 0.0, 0.0, 0.0)
            elif c.kind == "floating":
                now = self.qpos() if now is None else now
                q[c.qpos] = now[c.qpos]
        return q

    def positions(self, qpos) -> dict:
        """{joint: value} of the hinges and sliders of ``qpos`` (nq,): ``Robot.reset_joint_positions``'s
        argument."""
        q = self._check(qpos, self.nq, "qpos")
        return {c.name: float(q[c.qpos][0]) for c in self.coordinates if c.kind in ONE_DOF}

    def rates(self, qvel) -> dict:
        """{joint: rate} of the hinges and sliders of ``qvel`` (nv,), rad/s or m/s."""
        qd = self._check(qvel, self.nv, "qvel")
        return {c.name: float(qd[c.qvel][0]) for c in self.coordinates if c.kind in ONE_DOF}

    def integrate(self, qpos, qvel, h: float = 1.0) -> np.ndarray:
        """(nq,) the positions reached from ``qpos`` moving at ``qvel`` (nv,) for ``h`` s (MuJoCo's
        ``mj_integratePos``): balls and free rotations by the exponential map, the rest linearly."""
        q = self._check(qpos, self.nq, "qpos").copy()
        qd = self._check(qvel, self.nv, "qvel")
        for c in self.coordinates:
            qs, vs = q[c.qpos], qd[c.qvel]
            if c.kind in ONE_DOF:
                qs[0] += h * vs[0]
            elif c.kind == "spherical":  # the rate is in the child's frame: q <- q exp(w h)
                qs[:] = _quat_mul(qs, _quat_exp(vs, h))
                qs /= np.linalg.norm(qs)
            else:  # free: the origin in the world, the rotation by the body-frame rate
                qs[0:3] += h * vs[0:3]
                qs[3:7] = _quat_mul(qs[3:7], _quat_exp(vs[3:6], h))
                qs[3:7] /= np.linalg.norm(qs[3:7])
        return q

    def difference(self, qpos1, qpos0, h: float = 1.0) -> np.ndarray:
        """(nv,) the rates that take ``qpos0`` to ``qpos1`` (nq,) in ``h`` s: ``integrate``'s inverse
        (MuJoCo's ``mj_differentiatePos``; ``linearize.difference``)."""
        from .linearize import difference

        return difference(self, qpos1, qpos0, h)

    def transition_jacobians(self, sim, eps: float = 1e-6, centered: bool = True, inputs=None):
        """The next step as a linear map about the present state, by finite differences (MuJoCo's
        ``mjd_transitionFD``): a ``linearize.Linearization`` with ``A`` (2 nv, 2 nv) =
        d(qpos', qvel') / d(qpos, qvel) (positions in the tangent space, ``difference``) and ``B``
        (2 nv, nu) = d(qpos', qvel') / du, u the MJCF actuators' controls (``inputs="controls"``)
        or the hinges' and sliders' applied torques and forces (``"torques"``). Each column steps
        ``sim`` once from a snapshot of the present state moved by ``eps`` (both ways when
        ``centered``); ``sim`` is left as it was (module docstring of ``linearize``)."""
        from .linearize import transition_jacobians

        return transition_jacobians(self, sim, eps=eps, centered=centered, inputs=inputs)

    # ------------------------------------------------------------------ Jacobians and dynamics
    def _link(self, link) -> int:
        k = self.index.get(link) if isinstance(link, str) else None
        if k is None:
            raise InputError(f"unknown link {link!r} of robot {self.robot.name!r}", "link")
        return k

    def _jacobian_at(self, cols, k, p) -> np.ndarray:
        J = np.empty((6, self.nv))
        KK.jacobian_kernel(k, np.ascontiguousarray(p, dtype=float), self.ancestor, self.dof_link, *cols, J)
        return J

    def jacobian(self, link: str, point=(0.0, 0.0, 0.0), qpos=None) -> np.ndarray:
        """(6, nv) the Jacobian of a point fixed in ``link``: rows 0-2 its velocity (m/s), rows 3-5
        the link's angular velocity (rad/s), world frame, per joint rate (MuJoCo's ``mj_jac``
        jacp over jacr; PyBullet's ``calculateJacobian``). ``point`` (3,) m in the link frame;
        ``qpos`` (nq,) default the present state."""
        k = self._link(link)
        local = self._check(point, 3, "point")
        o, R = self._frames(qpos)
        return self._jacobian_at(self._columns(o, R), k, o[k] + R[k] @ local)

    def mass_matrix(self, qpos=None) -> np.ndarray:
        """(nv, nv) the joint-space inertia M(q) (kg m^2, kg m, kg), armature on the diagonal
        (MuJoCo's ``mj_fullM``; PyBullet's ``calculateMassMatrix``, which has no armature):
        sum over the bodies of m Jv^T Jv + Jw^T I_world Jw at their centres of mass."""
        o, R = self._frames(qpos)
        cols = self._columns(o, R)
        mass, com, I_world = self._bodies(o, R)
        M = np.empty((self.nv, self.nv))
        KK.mass_matrix_kernel(self.body_link, mass, com, I_world, self.ancestor, self.dof_link, *cols, self.armature, M)
        return M

    def point_acceleration(self, link: str, point=(0.0, 0.0, 0.0), qacc=None, qpos=None,
                           qvel=None) -> tuple[np.ndarray, np.ndarray]:
        """The acceleration (3,) m/s^2 of a point fixed in ``link`` (``point`` (3,) m, link frame)
        and the link's angular acceleration (3,) rad/s^2, world, at joint accelerations ``qacc``
        (nv,; default 0: then they are Jdot qd, the term an operational-space controller needs,
        MuJoCo's ``mj_jacDot`` times qvel), ``qpos`` and ``qvel`` (default the present state):
        J qdd + Jdot qd, from the recursive Newton-Euler forward pass (``link_motion_kernel``)."""
        k = self._link(link)
        local = self._check(point, 3, "point")
        o, R = self._frames(qpos)
        qd = self.qvel() if qvel is None else np.ascontiguousarray(self._check(qvel, self.nv, "qvel"))
        qdd = np.zeros(self.nv) if qacc is None else np.ascontiguousarray(self._check(qacc, self.nv, "qacc"))
        L = len(self.links)
        w, al, v, a = (np.empty((L, 3)) for _ in range(4))
        KK.link_motion_kernel(qd, qdd, o, R, self.parent, self.kind, self.axis, self.vadr, w, al, v, a)
        r = R[k] @ local
        return a[k] + np.cross(al[k], r) + np.cross(w[k], np.cross(w[k], r)), al[k].copy()

    def center_of_mass(self, qpos=None, link: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The centre of mass (3,) m, world, of the robot's moving bodies (or of those at and below
        ``link``) and its Jacobian (3, nv): its velocity per joint rate (MuJoCo's ``subtree_com``
        and ``mj_jacSubtreeCom``; balance and walking controllers), at ``qpos`` (default the
        present state): sum m x / sum m and sum m Jv / sum m over the bodies."""
        o, R = self._frames(qpos)
        cols = self._columns(o, R)
        mass, com, _I = self._bodies(o, R)
        chosen = np.ones(len(self.body_link), dtype=bool) if link is None else self.ancestor[self.body_link,
                                                                                               self._link(link)]
        total = float(mass[chosen].sum())
        if total <= 0.0:
            raise InputError("no moving body there: no centre of mass", "link")
        c = mass[chosen] @ com[chosen] / total
        J = np.zeros((3, self.nv))
        for b in np.flatnonzero(chosen):
            J += mass[b] * self._jacobian_at(cols, self.body_link[b], com[b])[0:3]
        return c, J / total

    def inverse_dynamics(self, qacc, qpos=None, qvel=None, gravity=None) -> np.ndarray:
        """(nv,) the joint forces (N m, N; a free joint's force world, its torque in its link
        frame) that give the accelerations ``qacc`` (nv,) at ``qpos`` (nq,) and ``qvel`` (nv,)
        (default: the present state), with ``gravity`` (3,) m/s^2 (default the world's):
        M(q) qdd + c(q, qd), armature included (module docstring;
        ``kinematics_kernels.inverse_dynamics_kernel``)."""
        qdd = np.ascontiguousarray(self._check(qacc, self.nv, "qacc"))
        o, R = self._frames(qpos)
        qd = self.qvel() if qvel is None else np.ascontiguousarray(self._check(qvel, self.nv, "qvel"))
        g = np.ascontiguousarray(self.world.gravity if gravity is None else self._check(gravity, 3, "gravity"),
                                 dtype=float)
        mass, com, I_world = self._bodies(o, R)
        tau = np.empty(self.nv)
        KK.inverse_dynamics_kernel(qd, qdd, g, o, R, self.parent, self.kind, self.axis, self.vadr, self.body_link,
                                   mass, com, I_world, self.armature, tau)
        return tau

    def bias_forces(self, qpos=None, qvel=None, gravity=None) -> np.ndarray:
        """(nv,) c(q, qd): Coriolis, centrifugal and gravity forces (MuJoCo's ``qfrc_bias``): the
        inverse dynamics of zero acceleration."""
        return self.inverse_dynamics(np.zeros(self.nv), qpos, qvel, gravity)

    def forward_dynamics(self, tau, qpos=None, qvel=None, gravity=None) -> np.ndarray:
        """(nv,) the accelerations qdd = M^-1 (tau - c(q, qd)) of the joint forces ``tau`` (nv,)
        with nothing else acting (no contacts, limits, damping): the Lagrangian reference the
        maximal-coordinate step is tested against."""
        t = self._check(tau, self.nv, "tau")
        return np.linalg.solve(self.mass_matrix(qpos), t - self.bias_forces(qpos, qvel, gravity))

    # ------------------------------------------------------------------ inverse kinematics
    def inverse_kinematics(self, link: str, position, orientation=None, point=(0.0, 0.0, 0.0), qpos=None,
                           max_iterations: int = 200, tolerance: float = 1e-6, angle_tolerance: float = 1e-6,
                           damping: float = 1e-3, restarts: int = 0, seed: int = 0) -> IkSolution:
        """Joint positions that put a point of ``link`` at ``position`` (3,) m, world, and (if given)
        the link frame at ``orientation`` (a quaternion (4,) w, x, y, z, or a rotation (3, 3)):
        PyBullet's ``calculateInverseKinematics``. Damped least squares (Levenberg-Marquardt;
        Buss, "Introduction to inverse kinematics with Jacobian transpose, pseudoinverse and damped
        least squares methods", 2004): dq = J^T (J J^T + lambda^2 I)^-1 e, from ``qpos``
        (default: the present state), each limited hinge and slider clamped to its range after
        every step. ``point`` (3,) m in the link frame. Stops when the position error is under
        ``tolerance`` m and the orientation error under ``angle_tolerance`` rad, when it stalls (10
        iterations without the error falling by 1 %, or the damping past 1e6), or after
        ``max_iterations``; the answer says which. A limit or a singular pose can hold the
        search in a local minimum: ``restarts`` more tries then start from joint positions drawn
        uniformly within the limits (hinges without limits in [-pi, pi]; the generator seeded by
        ``seed``, so the answer is reproducible), and the best try is returned. Gears between
        joints (URDF's mimic, MuJoCo's joint equalities: ``couplings``) are kept: a joint that
        follows another is set by it, not searched (a coupled joint's own limits are not)."""
        target = self._check(position, 3, "position")
        R_target = None
        if orientation is not None:
            o = np.asarray(orientation, dtype=float)
            if o.shape == (3, 3) and np.all(np.isfinite(o)):
                R_target = o
            else:
                R_target = quat_to_matrix(_unit_quat(self._check(o, 4, "orientation"), "orientation"))
        k = self._link(link)
        p_local = self._check(point, 3, "point")
        if not (damping >= 0.0 and math.isfinite(damping)):
            raise InputError(f"must be finite and >= 0, got {damping!r}", "damping")
        q = self.qpos() if qpos is None else self._check(qpos, self.nq, "qpos").copy()
        rows = 6 if R_target is not None else 3

        def error(q):
            o_all, R_all = self._frames(q)
            o, R = o_all[k], R_all[k]
            p = o + R @ p_local
            e = np.zeros(rows)
            e[0:3] = target - p
            if R_target is not None:  # the rotation vector taking R to R_target (world)
                E = R_target @ R.T
                angle = math.acos(max(-1.0, min(1.0, 0.5 * (float(np.trace(E)) - 1.0))))
                vee = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
                s = float(np.linalg.norm(vee))
                e[3:6] = vee * (angle / s) if s > 1e-12 else (np.zeros(3) if angle < 1.0 else _flip_axis(E) * angle)
            return e, (o_all, R_all), p

        couplings = self.couplings()

        def clamp(q):
            for c in self.coordinates:
                if c.kind in ONE_DOF and (c.lower is not None or c.upper is not None):
                    q[c.qpos] = np.clip(q[c.qpos], -np.inf if c.lower is None else c.lower,
                                        np.inf if c.upper is None else c.upper)
            for m, f, _, _, coef in couplings:  # a coupled joint on its relation (after its leader's clamp)
                q[m] = np.polynomial.polynomial.polyval(q[f] if f >= 0 else 0.0, coef)
            return q

        def descend(q, it):
            q = clamp(q)
            e, frames, p = error(q)
            lam = damping
            best, since = float(e @ e), 0
            while True:
                pos_err = float(np.linalg.norm(e[0:3]))
                ang_err = float(np.linalg.norm(e[3:6])) if R_target is not None else 0.0
                done = pos_err <= tolerance and ang_err <= angle_tolerance
                # a stall: lambda so large that no step is taken, or 10 iterations without the error
                # falling by 1 % (a limit or a singular pose holding it; a try converging gains orders
                # of magnitude in 10): the next restart's turn. (Each try used to run its 200
                # iterations out, crawling along a limit: 4 of 20 Kuka targets, 3.2 ms a target.)
                stalled = lam > 1e6 or since >= 10
                if done or stalled or it >= max_iterations:
                    return IkSolution(q, pos_err, ang_err, it, done)
                it += 1
                J = self._jacobian_at(self._columns(*frames), k, p)[0:rows]
                for m, f, mv, fv, coef in couplings:
                    # q_m = p(q_f): the coupled joint is no unknown of its own; its column moves with
                    # its leader's, scaled by p'(q_f) (dq_m = p'(q_f) dq_f)
                    if fv >= 0:
                        J[:, fv] += np.polynomial.polynomial.polyval(q[f], np.polynomial.polynomial.polyder(coef)) \
                            * J[:, mv]
                    J[:, mv] = 0.0
                # Levenberg-Marquardt's rule for lambda: a step that lowers the error is taken and
                # lambda halved; one that does not (a limit in the way, too long a step) is refused
                # and lambda quadrupled. A fixed lambda stalled on 8 of 20 random 6-D targets of the
                # Kuka arm from q = 0 (200 iterations); measured in tests/physics/test_kinematics.py.
                dq = J.T @ np.linalg.solve(J @ J.T + lam * lam * np.eye(rows), e)
                q_new = clamp(self.integrate(q, dq))
                e_new, frames_new, p_new = error(q_new)
                if e_new @ e_new < e @ e:
                    q, e, frames, p = q_new, e_new, frames_new, p_new
                    lam = max(0.5 * lam, 1e-12)
                else:
                    lam *= 4.0
                if float(e @ e) < 0.98 * best:  # the squared error down by 2 %: the error by 1 %
                    best, since = float(e @ e), 0
                else:
                    since += 1

        rng = np.random.default_rng(seed)
        best, used = None, 0
        for attempt in range(int(restarts) + 1):
            if attempt:
                q = self.neutral() if qpos is None else q.copy()
                for c in self.coordinates:
                    if c.kind in ONE_DOF:
                        lo = -math.pi if c.lower is None else c.lower
                        hi = math.pi if c.upper is None else c.upper
                        q[c.qpos] = rng.uniform(lo, hi)
            sol = descend(q, 0)
            used += sol.iterations
            if best is None or sol.position_error + sol.angle_error < best.position_error + best.angle_error:
                best = sol
            if sol.converged:
                break
        best.iterations = used
        return best


def _flip_axis(E):
    """The axis (3,) of a half turn E (3, 3): the column of E + I of largest norm, normalised."""
    B = E + np.eye(3)
    k = int(np.argmax(np.linalg.norm(B, axis=0)))
    return B[:, k] / np.linalg.norm(B[:, k])
