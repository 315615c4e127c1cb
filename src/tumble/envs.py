"""MuJoCo models as Gymnasium environments, stepped by tumble (``pip install 'tumble[rl]'``).

A learning library (Stable-Baselines3, CleanRL, RLlib) talks to an environment through
Gymnasium's API: ``reset(seed=)`` -> (observation, info), ``step(action)`` -> (observation,
reward, terminated, truncated, info), an ``action_space`` and an ``observation_space``. MuJoCo's
models come to it as ``gymnasium.envs.mujoco.MujocoEnv``; PyBullet's as ``pybullet_envs``. Here the
same model files come to it stepped by tumble, so a policy can be trained on one engine and tried
on the other (sim-to-sim transfer), or trained on tumble alone.

- ``ModelEnv(model, frame_skip=, timestep=, reset_noise_scale=)``: an MJCF file as an environment
  (MuJoCo's ``MujocoEnv``): the action is the actuators' controls in the file's order (MuJoCo's
  ``data.ctrl``, a ``Box`` over their ``ctrlrange``; ``Robot.set_controls``), the observation
  (qpos, qvel) in MuJoCo's layout (``Robot.kinematics``), one ``step`` is ``frame_skip`` steps of
  ``timestep`` (the file's ``<option timestep>``, MuJoCo's 0.002 s when it has none). A subclass
  says what the task is: ``observe`` (the observation), ``evaluate`` (reward, terminated, info)
  and, if it resets otherwise, ``draw_start``.
- ``InvertedPendulum``, ``InvertedDoublePendulum``, ``Reacher``, ``Pusher``, ``Swimmer``,
  ``HalfCheetah``, ``Hopper``, ``Walker2d`` and ``Ant``: Gymnasium's
  ``...-v5`` tasks on Gymnasium's own model files (read from the installed gymnasium), registered
  as ``tumble/InvertedPendulum-v5`` and so on with Gymnasium's episode limits:
  ``gymnasium.make("tumble/HalfCheetah-v5")`` once ``tumble.envs`` is imported. The runners
  (``_Runner``) stand, fall and run on the floor: contacts, in every step.
- ``ModelVectorEnv(env_class, num_envs)``: the copies in one World, one step for all
  (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``); copies that touch
  things each get an env of their own (``CollisionFilter.env``) over one floor.

Reset: ``reset(seed=s)`` puts the model at ``init_qpos`` and ``init_qvel`` plus uniform noise of
``reset_noise_scale``, drawn as Gymnasium's MuJoCo environments draw it (qpos first, then qvel, from
``self.np_random``): with the same seed, tumble's environment and Gymnasium's start from the same
state. ``Kinematics.set_state`` clears the joint solver's warm start of the model's joints, so the
same seed and the same actions give the same episode, bit for bit, whatever episodes came before
(tests/test_envs.py).

What differs from MuJoCo's environment is the engine: tumble's step (its joint solve in 4
substeps, docs/joints.md) against MuJoCo's integrator on the same ``timestep``
(tests/test_envs.py measures the two on the same actions; docs/robots.md "Gymnasium").
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import os

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
    from gymnasium.utils import seeding
    from gymnasium.vector import AutoresetMode, VectorEnv
    from gymnasium.vector.utils import batch_space
except ImportError:  # pragma: no cover - the message is the point
    raise ImportError("tumble.envs needs gymnasium: pip install 'tumble[rl]'") from None

from .errors import InputError

__all__ = ["ModelEnv", "ModelVectorEnv", "InvertedPendulum", "InvertedDoublePendulum", "Reacher", "HalfCheetah",
           "Hopper", "Walker2d", "Ant", "Humanoid", "HumanoidStandup", "Pusher", "Swimmer", "gymnasium_asset"]


def gymnasium_asset(name: str) -> str:
    """The path of one of Gymnasium's MuJoCo model files (``gymnasium/envs/mujoco/assets/NAME``),
    found without importing ``gymnasium.envs.mujoco`` (which needs the mujoco package)."""
    spec = importlib.util.find_spec("gymnasium")
    path = os.path.join(os.path.dirname(spec.origin), "envs", "mujoco", "assets", name)
    if not os.path.isfile(path):
        raise InputError(f"gymnasium {gymnasium.__version__} has no model file {name!r}", "model")
    return path


class _Copies:
    """``n`` copies of an MJCF model in one World, stepped by one Simulator (``ModelEnv``: 1,
    ``ModelVectorEnv``: many), and the model's controls and coordinates for all copies at once.

    Each copy is loaded at the model's own place. A model that touches nothing gets a filter that
    meets no body; one that touches (its floor, itself) gets each copy's bodies in an env of their
    own over the first copy's floor, so every copy moves as it would alone. The joint and contact
    solves treat each row with its own bodies only, in one order, so a copy's bits do not depend on
    the others (tests/test_envs.py, tests/test_envs_runners.py: copies equal single environments).

    The fast path (every coordinate a hinge or a slider but a free root's, every actuator on one
    joint of its own without a spring or damper: the motors of Gymnasium's models) writes the controls' efforts
    into the joint solver's rows and reads the coordinates from its readings (``JointSolver.store``,
    the end of the step; a free root's from its body, ``_root_state``) with array operations over
    all copies; the arithmetic is
    ``mjcf_control.apply_controls``'s, the same bits. Other models take ``Robot.set_controls`` and
    ``Kinematics.qpos``/``qvel`` copy by copy.
    """

    def __init__(self, model, n: int, timestep: float, joint_settings, contact_settings, margins: bool = False):
        import tumble as tb

        from .mjcf import read_option_gravity

        self.world = tb.World(gravity=tuple(read_option_gravity(model)))
        # no sleeping, as MuJoCo: a body at rest short of where its drives pull it would stay there
        # (measured: a position servo holding a pendulum against gravity fell asleep 1.3 mrad short)
        self.world.sleeping = False
        self.robots = [tb.load_mjcf(self.world, model, name=None if n == 1 else "env0", margins=margins)]
        self.touches = _touches_itself(self.world)  # the world holds the first copy alone
        w = self.world
        if not self.touches:
            # a model that cannot touch itself touches nothing (the world holds it alone): its bodies
            # get a filter that meets no body's, so copies pass through each other and the step skips
            # the collision stages (``collision.filter.live_filters``); Gymnasium's pendulums (MuJoCo
            # contype 0). Category and mask not 0: rays (the camera's) still see them.
            nothing = tb.CollisionFilter(category=1 << 31, mask=1 << 30)
            for i in range(w.body_count):
                w.body(i).collision_filter = nothing
            self.robots += [tb.load_mjcf(w, model, name=f"env{k}", collision_filter=nothing, margins=margins)
                            for k in range(1, n)]
        elif n > 1:
            # copies that touch: each in an env of its own (``CollisionFilter.env``: copy k's bodies
            # k + 1), over the first copy's floor and other <worldbody> geoms (env 0, met by every
            # copy; the others load without them). So each copy touches itself and the floor as it
            # would alone, and the broadphase keeps the copies in lanes (``broadphase.lane_bounds``).
            first = self.robots[0]
            statics = {link.index for key, link in first.links.items() if key.startswith("world/")}
            for i in range(w.body_count):
                if i not in statics:
                    w.body(i).collision_filter = dataclasses.replace(w.collision_filters[i], env=1)
            # the first copy's exclusions between its links and the floor (MuJoCo's contype and
            # conaffinity): the same pairs for every copy's links
            names = {link.index: key for key, link in first.links.items()}
            floor_pairs = [(names[a], names[b]) for a, b in w.excluded_collisions
                           if (a in statics) != (b in statics) and a in names and b in names]
            # and its explicit pairs' materials with the floor (MJCF <contact><pair>)
            floor_materials = [(names[a], names[b], m) for (a, b), m in w.pair_materials.items()
                               if (a in statics) != (b in statics) and a in names and b in names]
            for k in range(1, n):
                before = w.body_count
                robot = tb.load_mjcf(w, model, name=f"env{k}", world_geoms=False, margins=margins,
                                     collision_filter=tb.CollisionFilter(env=k + 1))
                for i in range(before, w.body_count):  # its links without geoms too (their filter meets nothing)
                    w.body(i).collision_filter = dataclasses.replace(w.collision_filters[i], env=k + 1)
                for a, b in floor_pairs:
                    w.exclude_collision(*(first.links[x] if x.startswith("world/") else robot.links[x] for x in (a, b)))
                for a, b, m in floor_materials:
                    w.set_pair_material(*(first.links[x] if x.startswith("world/") else robot.links[x] for x in (a, b)), m)
                self.robots.append(robot)
        if joint_settings is None:
            # the joints swept in one order on one thread, whatever their number: a copy's joints then
            # go in the single model's order (spatial slabs, JointSettings.partitions, would put some
            # of a chain's joints after the seam's, and the copies' bits would differ from a single
            # environment's); measured faster here too (1024 pendulums: 21.2 against 23.2 ms a step)
            from .solver.joints import ACCURATE, JointSettings

            # the Simulator's own default otherwise: the tree solve (ACCURATE) for a model with
            # armature, several joints in a body or equalities (Gymnasium's reacher: Gauss-Seidel's
            # soft rows let its target, on two slides through a 3e-6 kg virtual link, run away)
            base = ACCURATE if self.world.exact_joints else JointSettings()
            joint_settings = dataclasses.replace(base, partitions=1)
        if contact_settings is None:
            # the contacts too: in one order (slabs would reorder a copy's contacts past a seam)
            from .solver.contact import SoftStepSettings

            contact_settings = SoftStepSettings(partitions=1)
        self.sim = tb.Simulator(self.world, dt=timestep, joint_settings=joint_settings,
                                contact_settings=contact_settings)
        robot = self.robots[0]
        self.kinematics = [r.kinematics for r in self.robots]
        kin = self.kinematics[0]
        self.nq, self.nv = kin.nq, kin.nv
        self.actuators = list(robot.actuators)
        self.init_qpos = kin.qpos()
        self._fast = self._fast_path(robot, kin)
        self._solver_rows = (None, None)
        self._links = {}  # (link, point): (its body in each copy (n,), the point in the body (3,)), for link_origins
        self._bodies = None  # the file's bodies (``_file_bodies``)
        self._actuation = None  # (nu, nv) the actuators' efforts on the rates (``actuator_forces``)
        self._efforts = np.zeros((n, len(self.actuators)))  # (n, nu) N m or N, from the controls last set
        self.fresh = np.ones(n, dtype=bool)  # copies not stepped since put at a start: no constraint forces yet
        self.view = _View(self)

    def _fast_path(self, robot, kin):
        """The arrays of the fast path (class docstring), or None when the model does not take it."""
        from .joints import P_EFFORT
        from .kinematics import ONE_DOF

        coordinates = kin.coordinates
        root = coordinates[0] if coordinates and coordinates[0].kind == "floating" else None
        joints = coordinates[1:] if root is not None else coordinates
        if not all(c.kind in ONE_DOF for c in joints):
            return None
        acts = [robot.actuators[name] for name in self.actuators]
        driven = [a.joint for a in acts]
        if any(a.tendon or a.given is not None or a.stiffness != 0.0 or a.damping != 0.0 for a in acts) \
                or len(set(driven)) != len(driven):
            return None
        inf = np.inf
        fast = {
            "ctrl_lo": np.array([-inf if a.ctrlrange is None else a.ctrlrange[0] for a in acts]),
            "ctrl_hi": np.array([inf if a.ctrlrange is None else a.ctrlrange[1] for a in acts]),
            "force_lo": np.array([-inf if a.forcerange is None else a.forcerange[0] for a in acts]),
            "force_hi": np.array([inf if a.forcerange is None else a.forcerange[1] for a in acts]),
            "gain": np.array([a.gain for a in acts]), "b0": np.array([a.bias[0] for a in acts]),
            "gear": np.array([a.gear for a in acts]),
            # (n, nu) the joint records the actuators drive, (n, nq or nq - 7) those of the 1-D coordinates
            "driven": [[r.joints[j] for j in driven] for r in self.robots],
            "coordinate": [[r.joints[c.name] for c in joints] for r in self.robots],
            # where the 1-D coordinates go in qpos and qvel
            "qpos_cols": np.array([c.qpos.start for c in joints], dtype=np.int64),
            "qvel_cols": np.array([c.qvel.start for c in joints], dtype=np.int64),
            "column": P_EFFORT,
            "root": None,
        }
        if root is not None:
            # a free root (MuJoCo's free joint: the ant's, the humanoid's torso): its qpos and qvel
            # read from its body in every copy at once, as ``Kinematics.qpos``/``qvel`` read them
            k = kin.index[root.link]
            fast["root"] = (np.array([kn.link_body[k] for kn in self.kinematics], dtype=np.int64),
                            kin.link_p[k].copy(), kin.link_Rl[k].copy())
        fast["records"] = [rec.bound.param for row in fast["driven"] for rec in row]
        fast["actuators"] = [r.actuators[name] for r in self.robots for name in self.actuators]
        return fast

    def _rows(self):
        """((n, nu), (n, nq)) the joint solver's rows of the driven joints and of the coordinates (None
        before the first step after a restore: the solver is made by the step, from the records)."""
        solver = self.robots[0]._solver(self.sim)
        if solver is None:
            return None, None
        if self._solver_rows[0] is not solver:
            fast = self._fast
            self._solver_rows = (solver, tuple(np.array([[solver.index(rec) for rec in r] for r in fast[part]],
                                                        dtype=np.int64) for part in ("driven", "coordinate")))
        return solver, self._solver_rows[1]

    def set_controls(self, u: np.ndarray):
        """The controls ``u`` (n, nu) of every copy (MuJoCo's ``data.ctrl``), from the next step on."""
        fast = self._fast
        if fast is None:
            for c, (robot, row) in enumerate(zip(self.robots, u.tolist())):
                robot.set_controls(self.sim, dict(zip(self.actuators, row)))
                self._efforts[c] = [robot.actuators[name].drive() for name in self.actuators]
            return
        # mjcf_control.apply_controls's arithmetic: ctrl clipped to its range, gear (gain ctrl + b0)
        # with the force clipped to its range; + 0.0 as its sum starting from 0 (-0.0 becomes 0.0)
        ctrl = np.minimum(np.maximum(u, fast["ctrl_lo"]), fast["ctrl_hi"])
        force = np.minimum(np.maximum(fast["gain"] * ctrl + fast["b0"], fast["force_lo"]), fast["force_hi"])
        effort = fast["gear"] * force + 0.0
        self._efforts[:] = effort
        column = fast["column"]
        for param, value in zip(fast["records"], effort.ravel().tolist()):
            param[column] = value
        for actuator, value in zip(fast["actuators"], ctrl.ravel().tolist()):
            actuator.ctrl = value
        solver, rows = self._rows()
        if solver is not None:
            solver.param[rows[0], column] = effort

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """(qpos (n, nq), qvel (n, nv)) of every copy now."""
        solver, rows = self._rows() if self._fast is not None else (None, None)
        if solver is not None:
            fast = self._fast
            if fast["root"] is None:
                return solver.position[rows[1]], solver.rate[rows[1]]
            n = len(self.robots)
            qpos, qvel = np.empty((n, self.nq)), np.empty((n, self.nv))
            qpos[:, fast["qpos_cols"]] = solver.position[rows[1]]
            qvel[:, fast["qvel_cols"]] = solver.rate[rows[1]]
            self._root_state(qpos, qvel)
            return qpos, qvel
        return (np.array([k.qpos(self.sim) for k in self.kinematics]),
                np.array([k.qvel() for k in self.kinematics]))

    def _root_state(self, qpos: np.ndarray, qvel: np.ndarray):
        """Write the free root's qpos[:, :7] (its link frame's origin, m, world; its orientation as a
        unit quaternion w x y z, w >= 0) and qvel[:, :6] (its origin's velocity, m/s, world; its
        angular velocity, rad/s, in its own frame: MuJoCo's free joint) of every copy now, from its
        body (``Kinematics._present``'s and ``qvel``'s arithmetic, for all copies at once)."""
        from .math3d import matrix_to_quat_into

        b, link_p, link_Rl = self._fast["root"]
        w = self.world
        o, R = self._frames(b, link_p, link_Rl)
        qpos[:, 0:3] = o
        for c in range(len(b)):
            matrix_to_quat_into(np.ascontiguousarray(R[c]), qpos[c, 3:7])
        omega, v, r = w.omega[b], w.v[b], o - w.x[b]
        # v + omega x r, written as Kinematics.qvel writes it
        qvel[:, 0] = v[:, 0] + omega[:, 1] * r[:, 2] - omega[:, 2] * r[:, 1]
        qvel[:, 1] = v[:, 1] + omega[:, 2] * r[:, 0] - omega[:, 0] * r[:, 2]
        qvel[:, 2] = v[:, 2] + omega[:, 0] * r[:, 1] - omega[:, 1] * r[:, 0]
        qvel[:, 3:6] = np.einsum("nji,nj->ni", R, omega)

    def link_origins(self, link: str, point=None) -> np.ndarray:
        """(n, 3) m, world: the origin of ``link``'s frame in each copy now, or the ``point`` (3,) m
        given in that frame (a site: ``robot.sites[name]``'s position) (``Kinematics._present``'s
        arithmetic, for one link of all copies)."""
        key = (link, None if point is None else tuple(float(c) for c in point))
        cached = self._links.get(key)
        if cached is None:
            kin = self.kinematics[0]
            if link not in kin.index:
                raise InputError(f"unknown link {link!r} of the model", "link")
            k = kin.index[link]
            p = kin.link_p[k].copy() if point is None else kin.link_p[k] + kin.link_Rl[k] @ np.asarray(key[1])
            cached = (np.array([kn.link_body[k] for kn in self.kinematics], dtype=np.int64), p)
            self._links[key] = cached
        b, p = cached
        return self._frames(b, p)[0]

    def _frames(self, b, link_p, link_Rl=None):
        """The frames of links in their bodies ``b`` (int array, any shape S) now: (origins (S, 3) m,
        world; rotations (S, 3, 3), or None without ``link_Rl``), each link at ``link_p`` (3,) m
        and ``link_Rl`` (3, 3) in its body's shape frame (arrays broadcast against S)
        (``Kinematics._present``'s arithmetic, for many bodies at once)."""
        w = self.world
        Rb = w.R[b]
        origin = w.x[b] - np.einsum("...ij,...j->...i", Rb, w.com_offset[b]) + np.einsum("...ij,...j->...i", Rb, link_p)
        return origin, None if link_Rl is None else np.einsum("...ij,...jk->...ik", Rb, link_Rl)

    def limit_force(self, joint: str) -> np.ndarray:
        """(n,) N or N m: the force (torque) ``joint``'s limits applied along its coordinate in each
        copy over the last substep of the last step (lower limit +, upper -): MuJoCo's
        ``qfrc_constraint`` of a hinge or slide coordinate with no other constraint on it. 0 for
        copies not stepped since their start (MuJoCo's reset computes none for a joint within its
        range)."""
        from .solver.joint_solve import A_LOWER, A_UPPER

        solver = self.robots[0]._solver(self.sim)
        out = np.zeros(len(self.robots))
        if solver is None:
            return out
        rows = np.array([solver.index(r.joints[joint]) for r in self.robots], dtype=np.int64)
        out[:] = (solver.axial_impulse[rows, A_LOWER] - solver.axial_impulse[rows, A_UPPER]) / solver.h
        out[self.fresh] = 0.0
        return out

    def _file_bodies(self):
        """The model's bodies as MuJoCo has them (the file's, the world and tumble's virtual links
        left out), cached: a namespace of ``names`` (B,) in the file's order (MuJoCo's body order,
        less the world), ``body`` (n, B) each one's tumble body in each copy, ``link_p`` (B, 3) m
        and ``link_Rl`` (B, 3, 3) its frame in that body's shape frame, ``mass`` (B,) kg,
        ``center`` (B, 3) m and ``inertia`` (B, 3, 3) kg m^2 its own inertial in its frame (a
        body welded into its parent keeps its own here: MuJoCo's ``body_mass``, ``body_ipos``),
        and ``part_row`` / ``part_copy`` / ``part_first`` (each world body's compound parts: part
        k of world body i is row ``part_row[part_first[i] + k]`` (-1: none) of copy
        ``part_copy[...]``)."""
        if self._bodies is not None:
            return self._bodies
        from types import SimpleNamespace

        robot, w = self.robots[0], self.world
        model = robot.model
        names = [k for k in model.links if k != "world" and k not in robot.virtual_links]
        kin = self.kinematics[0]
        at = np.array([kin.index[name] for name in names], dtype=np.int64)
        links = [model.links[name] for name in names]
        # each world body's parts, by the links it holds in the file's order (``urdf._add_link_body``)
        counts = np.zeros(w.body_count, dtype=np.int64)
        rows = [[] for _ in range(w.body_count)]
        copies = [[] for _ in range(w.body_count)]
        for c, r in enumerate(self.robots):
            for link_name, link in model.links.items():
                if link_name == "world" or r.owners.get(link_name) is None:
                    continue
                i = r.links[link_name].index
                row = names.index(link_name) if link_name in names else -1
                rows[i] += [row] * len(link.parts)
                copies[i] += [c] * len(link.parts)
        for i in range(w.body_count):
            counts[i] = max(len(rows[i]), 1)
            if not rows[i]:
                rows[i], copies[i] = [-1], [-1]
        self._bodies = SimpleNamespace(
            names=names, body=np.array([k.link_body[at] for k in self.kinematics], dtype=np.int64),
            link_p=kin.link_p[at].copy(), link_Rl=kin.link_Rl[at].copy(),
            mass=np.array([link.mass for link in links]), center=np.array([link.center for link in links], dtype=float),
            inertia=np.array([link.inertia for link in links], dtype=float),
            part_first=np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64),
            part_row=np.array([x for row in rows for x in row], dtype=np.int64),
            part_copy=np.array([x for row in copies for x in row], dtype=np.int64))
        return self._bodies

    def _mass_frames(self):
        """The file's bodies now (``_file_bodies``): (centres of mass (n, B, 3) m, world; rotations
        of their frames (n, B, 3, 3); each copy's centre of mass (n, 3) m, MuJoCo's ``subtree_com``
        of the root: sum m xipos / sum m over the file's bodies)."""
        f = self._file_bodies()
        origin, R = self._frames(f.body, f.link_p, f.link_Rl)
        xipos = origin + np.einsum("nbij,bj->nbi", R, f.center)
        com = np.einsum("b,nbj->nj", f.mass, xipos) / f.mass.sum()
        return xipos, R, com

    def center_of_mass(self) -> np.ndarray:
        """(n, 3) m, world: each copy's centre of mass now (MuJoCo's ``subtree_com`` of the root;
        Gymnasium's ``mass_center``: the file's bodies' masses, not tumble's virtual links')."""
        return self._mass_frames()[2]

    def com_inertia(self) -> np.ndarray:
        """(n, B, 10) each copy's MuJoCo ``cinert[1:]`` now: per body of the file, its inertia about
        the copy's centre of mass in world axes (xx, yy, zz, xy, xz, yz; kg m^2: its own, rotated,
        plus m (|d|^2 1 - d d^T)), then m d (kg m) and m (kg), d its centre of mass less the
        copy's (MuJoCo's ``mju_inertCom``)."""
        f = self._file_bodies()
        xipos, R, com = self._mass_frames()
        inertia = np.einsum("nbij,bjk,nblk->nbil", R, f.inertia, R)
        d = xipos - com[:, None, :]
        m = f.mass[None, :]
        dx, dy, dz = d[..., 0], d[..., 1], d[..., 2]
        return np.stack([inertia[..., 0, 0] + m * (dy * dy + dz * dz), inertia[..., 1, 1] + m * (dx * dx + dz * dz),
                         inertia[..., 2, 2] + m * (dx * dx + dy * dy), inertia[..., 0, 1] - m * dx * dy,
                         inertia[..., 0, 2] - m * dx * dz, inertia[..., 1, 2] - m * dy * dz,
                         m * dx, m * dy, m * dz, np.broadcast_to(m, dx.shape)], axis=-1)

    def com_velocity(self) -> np.ndarray:
        """(n, B, 6) each copy's MuJoCo ``cvel[1:]`` now: per body of the file, its angular velocity
        (rad/s) then the velocity (m/s) of its point at the copy's centre of mass, world axes."""
        f, w = self._file_bodies(), self.world
        com = self._mass_frames()[2]
        b = f.body
        omega = w.omega[b]
        v = w.v[b] + np.cross(omega, com[:, None, :] - w.x[b])
        return np.concatenate([omega, v], axis=-1)

    def actuator_forces(self) -> np.ndarray:
        """(n, nv) each copy's MuJoCo ``qfrc_actuator``: its actuators' forces on its coordinates from
        the controls last set (a motor's gear (gain ctrl + b0), clipped to its force range; through
        a fixed tendon, times each joint's coefficient), 0 for a copy not stepped since its start
        (MuJoCo's reset zeroes ``ctrl``). Models with servos (a force that depends on the state)
        are refused: an InputError."""
        if self._actuation is None:
            kin, robot = self.kinematics[0], self.robots[0]
            G = np.zeros((len(self.actuators), self.nv))  # the effort of actuator a on rate k
            for a, name in enumerate(self.actuators):
                act = robot.actuators[name]
                if act.stiffness != 0.0 or act.damping != 0.0 or act.given is not None:
                    raise InputError(f"actuator {name!r} is a servo: its force is not read (motors only)", "model")
                for joint, coef in (act.tendon or ((act.joint, 1.0),)):
                    G[a, kin.by_name[joint].qvel] += coef
            self._actuation = G
        out = self._efforts @ self._actuation
        out[self.fresh] = 0.0
        return out

    def external_forces(self) -> np.ndarray:
        """(n, B, 6) each copy's MuJoCo ``cfrc_ext[1:]`` after the last step: per body of the file (B,
        in the file's order, the world left out), the contacts' forces on it over the step (N) and
        their torque (N m) about the copy's centre of mass (MuJoCo's ``subtree_com`` of the root),
        torque first, world axes. A body welded into its parent (MuJoCo's body, a part of tumble's)
        has its own contacts: those of its geoms' parts (``Contacts.part_a``, ``part_b``)."""
        f = self._file_bodies()
        n, B = len(self.robots), len(f.names)
        if self.fresh.all():
            return np.zeros((n, B, 6))
        com = self._mass_frames()[2]
        out = np.zeros((n, B, 6))
        c = self.sim.contacts()
        for body, part, sign in ((c.body_a, c.part_a, -1.0), (c.body_b, c.part_b, 1.0)):
            at = f.part_first[body] + part
            row, copy = f.part_row[at], f.part_copy[at]
            ok = row >= 0
            copy = copy[ok]
            force = sign * c.force[ok]
            np.add.at(out, (copy, row[ok]), np.concatenate([np.cross(c.point[ok] - com[copy], force), force], axis=1))
        out[self.fresh] = 0.0  # a copy just reset has had no step (MuJoCo's reset zeroes cfrc_ext)
        return out

    def set_states(self, copies, qpos: np.ndarray, qvel: np.ndarray):
        """Put the ``copies`` (K indices) at ``qpos`` (K, nq) moving at ``qvel`` (K, nv)
        (``Kinematics.set_state`` for each: its joints' warm start cleared, their readings set; the
        world's derived quantities made once for all)."""
        self.fresh[copies] = True
        placed = [self.kinematics[k]._place(qp, qv) for k, qp, qv in zip(copies, qpos, qvel)]
        self.world.update_derived()
        for k, q, qv in zip(copies, placed, qvel):
            self.robots[k]._restart_warm_starts(self.sim, self.kinematics[k].positions(q), self.kinematics[k].rates(qv))
        solver, rows = self._rows() if self._fast is not None else (None, None)
        if solver is not None:  # the readings a step would leave, for ``state``
            solver.position[rows[1][copies]] = qpos[:, self._fast["qpos_cols"]]
            solver.rate[rows[1][copies]] = qvel[:, self._fast["qvel_cols"]]


class _View:
    """What a task's ``observe`` may read of the copies besides qpos and qvel (its ``links``
    argument): ``links(name, point=None)`` (n, 3) m, the origin of a link's frame (or a point in
    it: a site) in each copy now; ``links.limit_force(joint)`` (n,) the force of a joint's limits
    (``_Copies.limit_force``); ``links.external_forces()`` (n, B, 6) MuJoCo's ``cfrc_ext[1:]``;
    ``links.center_of_mass()`` (n, 3) its ``subtree_com`` of the root, ``links.com_inertia()`` (n,
    B, 10) its ``cinert[1:]``, ``links.com_velocity()`` (n, B, 6) its ``cvel[1:]``,
    ``links.actuator_forces()`` (n, nv) its ``qfrc_actuator`` (``_Copies``' methods of those names)."""

    def __init__(self, copies):
        self._copies = copies

    def __call__(self, link: str, point=None) -> np.ndarray:
        return self._copies.link_origins(link, point)

    def limit_force(self, joint: str) -> np.ndarray:
        return self._copies.limit_force(joint)

    def external_forces(self) -> np.ndarray:
        return self._copies.external_forces()

    def center_of_mass(self) -> np.ndarray:
        return self._copies.center_of_mass()

    def com_inertia(self) -> np.ndarray:
        return self._copies.com_inertia()

    def com_velocity(self) -> np.ndarray:
        return self._copies.com_velocity()

    def actuator_forces(self) -> np.ndarray:
        return self._copies.actuator_forces()


def _touches_itself(world) -> bool:
    """Whether two bodies of ``world`` (one model, ``load_mjcf``) with shapes, one of them moving,
    may touch (``World.should_collide``: filters, exclusions, MuJoCo's contype/conaffinity)."""
    shaped = [i for i in range(world.body_count) if world.shapes[i] is not None]
    return any((world.moving[a] or world.moving[b]) and world.should_collide(a, b)
               for k, a in enumerate(shaped) for b in shaped[k + 1:])


def _check_settings(frame_skip, timestep, reset_noise_scale, model):
    from .mjcf import read_option_timestep

    if isinstance(frame_skip, bool) or not isinstance(frame_skip, (int, np.integer)) or frame_skip < 1:
        raise InputError(f"must be a whole number of steps >= 1, got {frame_skip!r}", "frame_skip")
    timestep = read_option_timestep(model) if timestep is None else timestep
    if isinstance(timestep, bool) or not isinstance(timestep, (int, float)) or not (0.0 < timestep < np.inf):
        raise InputError(f"must be a positive number of seconds, got {timestep!r}", "timestep")
    if isinstance(reset_noise_scale, bool) or not isinstance(reset_noise_scale, (int, float)) \
            or not (0.0 <= reset_noise_scale < np.inf):
        raise InputError(f"must be a number >= 0, got {reset_noise_scale!r}", "reset_noise_scale")
    return int(frame_skip), float(timestep), float(reset_noise_scale)


def _check_actions(a, n: int, nu: int):
    u = np.asarray(a, dtype=np.float64)
    if u.shape != (n, nu) or not np.isfinite(u).all():  # (not np.all: its Python wrapper, every env step)
        want = f"({nu},)" if n == 1 else f"({n}, {nu})"
        raise InputError(f"expected finite controls of shape {want}, got {np.asarray(a)!r}", "action")
    return u


class ModelEnv(gymnasium.Env):
    """An MJCF model as a Gymnasium environment stepped by tumble (module docstring).

    Args:
        model: the MJCF file.
        frame_skip: simulator steps per ``step`` (MuJoCo's ``MujocoEnv`` ``frame_skip``).
        timestep: s, the simulator's dt (default: the file's ``<option timestep>``).
        reset_noise_scale: the half-width of the uniform noise added to ``init_qpos`` and
            ``init_qvel`` at each reset (0: none).
        joint_settings, contact_settings: the Simulator's (``tumble.solver``'s settings).
        render_mode: None or ``"rgb_array"`` (``render()`` returns a (H, W, 3) uint8 image from
            ``camera``, a ``tb.Camera``; default one looking at the model's start from the side).
            ``metadata["render_fps"]`` is ``int(round(1 / dt))`` (MujocoEnv's), the rate a video of
            the steps plays at; ``gymnasium.make(id, render_mode="human")`` shows the frames in a
            window through Gymnasium's ``HumanRendering`` (it needs pygame and a display).

    Attributes:
        world, sim, robot: the World, its Simulator and the model (``urdf.Robot``).
        init_qpos (nq,), init_qvel (nv,): the start before noise (the model's pose, at rest).
        actuators: the actuators' names, in the action's order.

    A task (a subclass) gives ``observe`` and ``evaluate`` over a batch of copies (arrays with a
    leading axis), so that ``ModelVectorEnv`` runs it for all its copies at once.
    """

    metadata = {"render_modes": ["rgb_array"]}
    #: the file's geom margins read (``load_mjcf(margins=)``): a task whose model rests on them in MuJoCo
    margins = False

    def __init__(self, model, *, frame_skip: int = 1, timestep: float | None = None,
                 reset_noise_scale: float = 0.0, joint_settings=None, contact_settings=None,
                 render_mode: str | None = None, camera=None):
        import tumble as tb

        self.frame_skip, self.timestep, self.reset_noise_scale = _check_settings(
            frame_skip, timestep, reset_noise_scale, model)
        if render_mode == "human":
            raise InputError("'human' is not drawn by tumble (it draws off screen, 'rgb_array'); "
                             "gymnasium.make(id, render_mode='human') shows the 'rgb_array' frames in a "
                             "pygame window (Gymnasium's HumanRendering wrapper)", "render_mode")
        if render_mode not in (None, "rgb_array"):
            raise InputError(f"expected None or 'rgb_array', got {render_mode!r}", "render_mode")
        self.model = str(model)
        self.render_mode = render_mode
        self._copies = _Copies(model, 1, self.timestep, joint_settings, contact_settings, self.margins)
        self.world, self.sim, self.robot = self._copies.world, self._copies.sim, self._copies.robots[0]
        self.actuators = self._copies.actuators
        self.init_qpos = self._copies.init_qpos
        self.init_qvel = np.zeros(self._copies.nv)
        self.action_space, self.observation_space = _spaces(self)
        # frames per second of a video of steps (RecordVideo, HumanRendering): MujocoEnv's rule
        self.metadata = {**type(self).metadata, "render_fps": int(round(1.0 / self.dt))}
        if camera is None:
            camera = tb.Camera(position=(0.0, -3.0, 1.0), target=(0.0, 0.0, 0.3), width=320, height=240)
        self.camera = camera

    @property
    def dt(self) -> float:
        """s, the time one ``step`` covers: ``timestep`` x ``frame_skip`` (MujocoEnv's ``dt``)."""
        return self.timestep * self.frame_skip

    # ------------------------------------------------------------------ the task (subclasses)
    def observe(self, qpos: np.ndarray, qvel: np.ndarray, links=None) -> np.ndarray:
        """The observations (n, d) of n copies at ``qpos`` (n, nq) moving at ``qvel`` (n, nv):
        here (qpos, qvel) side by side. ``links(name)``: the world positions (n, 3) m of a link's
        frame origin in each copy now (a task's fingertip, MuJoCo's ``get_body_com`` where the
        body's centre of mass is its origin)."""
        return np.concatenate([qpos, qvel], axis=1)

    def draw_start(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(qpos (nq,), qvel (nv,)) of a reset: ``init_qpos`` and ``init_qvel`` plus uniform noise of
        ``reset_noise_scale``, drawn qpos first, then qvel (as Gymnasium's MuJoCo environments'
        ``reset_model``: the same draws from the same generator)."""
        s = self.reset_noise_scale
        qpos = self.init_qpos + rng.uniform(low=-s, high=s, size=len(self.init_qpos))
        qvel = self.init_qvel + rng.uniform(low=-s, high=s, size=len(self.init_qvel))
        return qpos, qvel

    def evaluate(self, observation: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
        """(reward (n,), terminated (n,) bool, info {key: (n,)}) of n copies after a step that took
        ``action`` (n, nu) to ``observation`` (n, d): no task here (zeros, False, {})."""
        n = len(observation)
        return np.zeros(n), np.zeros(n, dtype=bool), {}

    def remember(self, qpos: np.ndarray, qvel: np.ndarray, links=None):
        """Called with the copies' ``qpos`` (n, nq) and ``qvel`` (n, nv) (and ``links``, as
        ``observe``'s) before each step, for a task whose reward compares the step's start with its
        end (a runner's forward speed, as Gymnasium's locomotion tasks measure it: the root's x
        moved over ``dt``): nothing here."""

    def reset_info(self, qpos: np.ndarray, qvel: np.ndarray) -> dict:
        """The info {key: (n,)} that ``reset`` returns for copies starting at ``qpos`` (n, nq),
        ``qvel`` (n, nv): none here."""
        return {}

    # ------------------------------------------------------------------ Gymnasium's API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """The model at ``init_qpos`` and ``init_qvel`` plus the reset noise (module docstring
        "Reset"): (observation, info)."""
        super().reset(seed=seed)
        qpos, qvel = self.draw_start(self.np_random)
        self._copies.set_states([0], qpos[None], qvel[None])
        info = {k: _one(v) for k, v in self.reset_info(qpos[None], qvel[None]).items()}
        return self.observe(qpos[None], qvel[None], self._copies.view)[0], info

    def set_state(self, qpos, qvel):
        """Put the model at ``qpos`` (nq,) moving at ``qvel`` (nv,) (MujocoEnv's ``set_state``)."""
        self._copies.set_states([0], np.asarray(qpos, dtype=float)[None], np.asarray(qvel, dtype=float)[None])

    def step(self, action):
        """``frame_skip`` steps with the controls ``action`` (nu,): (observation, reward,
        terminated, truncated (always False: a ``TimeLimit`` wrapper truncates), info)."""
        u = _check_actions(np.asarray(action)[None], 1, len(self.actuators))
        self._copies.set_controls(u)
        self.remember(*self._copies.state(), self._copies.view)
        self.sim.step(self.frame_skip)
        self._copies.fresh[:] = False
        obs = self.observe(*self._copies.state(), self._copies.view)
        reward, terminated, info = self.evaluate(obs, u)
        return obs[0], reward[0].item(), bool(terminated[0]), False, {k: _one(v) for k, v in info.items()}

    def render(self):
        """A (H, W, 3) uint8 image of the present state from ``camera`` (``render_mode="rgb_array"``),
        else None."""
        if self.render_mode != "rgb_array":
            return None
        return self.camera.capture(self.world).rgb


def _one(value):
    """The first copy's entry of an info value (n,) or (n, k): a Python number, or a (k,) array
    (Gymnasium's humanoid's tendon lengths)."""
    value = np.asarray(value)
    return value[0].item() if value.ndim == 1 else value[0].copy()


def _spaces(env):
    """(action space, observation space) of one copy: the controls' ranges (float32, as MuJoCo's
    environments make theirs, ``MujocoEnv._set_action_space``), the observation unbounded."""
    low, high = [], []
    for name in env.actuators:
        r = env.robot.actuators[name].ctrlrange
        low.append(-np.inf if r is None else r[0])
        high.append(np.inf if r is None else r[1])
    action = spaces.Box(np.array(low, dtype=np.float32), np.array(high, dtype=np.float32), dtype=np.float32)
    size = env.observe(env.init_qpos[None], env.init_qvel[None], env._copies.view).shape[1]
    return action, spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)


class InvertedPendulum(ModelEnv):
    """Gymnasium's ``InvertedPendulum-v5`` stepped by tumble: a cart on a rail (a slide joint,
    -1..1 m) pushed by a motor (gear 100, control in [-3, 3]) with a pole on a hinge, on Gymnasium's
    own ``inverted_pendulum.xml``. Observation (cart x, pole angle, their rates) (4,); reward 1
    while the pole is within 0.2 rad of upright and the observation finite, terminated
    otherwise (with reward 0, as v5 gives it); ``info["reward_survive"]`` the reward. Timestep
    0.02 s (the file's), ``frame_skip`` 2 (``dt`` 0.04 s), reset noise 0.01: Gymnasium's defaults.
    """

    def __init__(self, *, frame_skip: int = 2, timestep: float | None = None, reset_noise_scale: float = 0.01,
                 **kwargs):
        super().__init__(gymnasium_asset("inverted_pendulum.xml"), frame_skip=frame_skip, timestep=timestep,
                         reset_noise_scale=reset_noise_scale, **kwargs)

    def evaluate(self, observation, action):
        terminated = ~np.all(np.isfinite(observation), axis=1) | (np.abs(observation[:, 1]) > 0.2)
        reward = (~terminated).astype(np.float64)
        return reward, terminated, {"reward_survive": reward}


class Reacher(ModelEnv):
    """Gymnasium's ``Reacher-v5`` stepped by tumble: a two-link arm on a table (two hinges, armature
    1 and damping 1, motors of gear 200 with controls in [-1, 1]) reaching for a target (a body on
    two slides, ``ref`` 0.1 and -0.1 m), on Gymnasium's own ``reacher.xml``. Observation (10,):
    cos and sin of the two angles, the target's x and y (qpos), the arm's two rates, the fingertip
    less the target (x, y); reward -|fingertip - target| - |action|^2 (v5's weights 1 and 1;
    ``info["reward_dist"]``, ``info["reward_ctrl"]``); never terminated (50 steps an episode).
    Reset as v5's: the angles and the target's coordinates +-0.1 about ``init_qpos``, then the
    target put at a goal drawn uniformly in the square of half-side 0.2 until it lies within 0.2 m
    of the centre, the rates +-0.005 with the target's zero. Timestep 0.01 s (the file's),
    ``frame_skip`` 2."""

    def __init__(self, *, frame_skip: int = 2, timestep: float | None = None, **kwargs):
        super().__init__(gymnasium_asset("reacher.xml"), frame_skip=frame_skip, timestep=timestep, **kwargs)

    def draw_start(self, rng):
        qpos = rng.uniform(low=-0.1, high=0.1, size=len(self.init_qpos)) + self.init_qpos
        while True:
            goal = rng.uniform(low=-0.2, high=0.2, size=2)
            if np.linalg.norm(goal) < 0.2:
                break
        qpos[-2:] = goal
        qvel = self.init_qvel + rng.uniform(low=-0.005, high=0.005, size=len(self.init_qvel))
        qvel[-2:] = 0.0
        return qpos, qvel

    def observe(self, qpos, qvel, links=None):
        theta = qpos[:, :2]
        self._reach = links("fingertip") - links("target")  # (n, 3), for evaluate
        return np.concatenate([np.cos(theta), np.sin(theta), qpos[:, 2:], qvel[:, :2], self._reach[:, :2]], axis=1)

    def evaluate(self, observation, action):
        reward_dist = -np.linalg.norm(self._reach, axis=1)
        reward_ctrl = -np.square(action).sum(axis=1)
        return reward_dist + reward_ctrl, np.zeros(len(observation), dtype=bool), \
            {"reward_dist": reward_dist, "reward_ctrl": reward_ctrl}


class InvertedDoublePendulum(ModelEnv):
    """Gymnasium's ``InvertedDoublePendulum-v5`` stepped by tumble, on its own
    ``inverted_double_pendulum.xml``: a cart on a rail (a slide, -1..1 m, pushed by a motor of gear
    500, control in [-1, 1]) with two poles on hinges; timestep 0.01 s, ``frame_skip`` 5. Observation
    (9,): the cart's x, the sines then cosines of the two angles, the three rates clipped to +-10,
    and the rail's limit force on the cart clipped to +-10 (MuJoCo's ``qfrc_constraint[0]``:
    ``_Copies.limit_force``; 0 while the cart is clear of the rail's ends). Reward: 10 while the
    tip (the file's site, world height y) is above 1 m, less 0.01 x_tip^2 + (y_tip - 2)^2 less
    1e-3 w1^2 + 5e-3 w2^2 (the hinges' rates); terminated when y_tip <= 1 m. Reset noise 0.1
    (qpos uniform, qvel normal), ``healthy_reward`` 10: v5's defaults. MuJoCo's rail limit is soft,
    with a margin of 1 cm; tumble's is rigid, at the range: the force observed near the ends
    differs (the rest is the same arithmetic: tests/test_envs_runners.py)."""

    def __init__(self, *, frame_skip: int = 5, healthy_reward: float = 10.0, reset_noise_scale: float = 0.1,
                 **kwargs):
        self.healthy_reward = _weight(healthy_reward, "healthy_reward")
        super().__init__(gymnasium_asset("inverted_double_pendulum.xml"), frame_skip=frame_skip,
                         reset_noise_scale=reset_noise_scale, **kwargs)
        self._tip = self.robot.sites["tip"][:2]  # (link, position in its frame)

    def draw_start(self, rng):
        s = self.reset_noise_scale
        qpos = self.init_qpos + rng.uniform(low=-s, high=s, size=len(self.init_qpos))
        qvel = self.init_qvel + rng.standard_normal(len(self.init_qvel)) * s
        return qpos, qvel

    def observe(self, qpos, qvel, links=None):
        n = len(qpos)
        if links is None or not hasattr(self, "_tip"):  # the spaces, made before the site is known
            self._tip_xyz, force = np.zeros((n, 3)), np.zeros(n)
        else:
            self._tip_xyz, force = links(*self._tip), links.limit_force("slider")
        self._rates = qvel
        return np.concatenate([qpos[:, :1], np.sin(qpos[:, 1:]), np.cos(qpos[:, 1:]), np.clip(qvel, -10, 10),
                               np.clip(force, -10, 10)[:, None]], axis=1)

    def evaluate(self, observation, action):
        x, y = self._tip_xyz[:, 0], self._tip_xyz[:, 2]
        terminated = y <= 1
        v1, v2 = self._rates[:, 1], self._rates[:, 2]
        distance = 0.01 * x ** 2 + (y - 2) ** 2
        velocity = 1e-3 * v1 ** 2 + 5e-3 * v2 ** 2
        alive = self.healthy_reward * (~terminated)
        return alive - distance - velocity, terminated, {"reward_survive": alive, "distance_penalty": -distance,
                                                         "velocity_penalty": -velocity}


class Pusher(ModelEnv):
    """Gymnasium's ``Pusher-v5`` stepped by tumble, on its ``pusher_v5.xml``: a seven-joint arm
    (motors, controls in [-2, 2]) pushing a cylinder (a body on two slides) over a table towards
    a goal (a body on two slides it never touches); timestep 0.01 s, ``frame_skip`` 5.
    Observation (23,): the arm's 7 angles and 7 rates, then the world positions of the fingertip
    (``tips_arm``), the object and the goal (their frames' origins: MuJoCo's ``get_body_com``,
    which reads ``xpos``). Reward: -``reward_near_weight`` |object - tip| -
    ``reward_dist_weight`` |object - goal| - ``reward_control_weight`` |action|^2 (0.5, 1, 0.1);
    never terminated (100 steps an episode). Reset as v5's: the arm at its pose, the goal at the
    origin of its slides, the object's two slide coordinates drawn uniform in [-0.3, 0] and
    [-0.2, 0.2] until they lie more than 0.17 from the goal's, the rates +-0.005 but the object's
    and the goal's 0. The object slides and is pushed on tumble's contacts (the arm's, the table's)."""

    def __init__(self, *, frame_skip: int = 5, reward_near_weight: float = 0.5, reward_dist_weight: float = 1.0,
                 reward_control_weight: float = 0.1, **kwargs):
        self.weights = (_weight(reward_near_weight, "reward_near_weight"),
                        _weight(reward_dist_weight, "reward_dist_weight"),
                        _weight(reward_control_weight, "reward_control_weight"))
        super().__init__(gymnasium_asset("pusher_v5.xml"), frame_skip=frame_skip, **kwargs)

    def draw_start(self, rng):
        qpos = self.init_qpos.copy()
        goal = np.zeros(2)
        while True:
            cylinder = np.concatenate([rng.uniform(low=-0.3, high=0, size=1), rng.uniform(low=-0.2, high=0.2, size=1)])
            if np.linalg.norm(cylinder - goal) > 0.17:
                break
        qpos[-4:-2] = cylinder
        qpos[-2:] = goal
        qvel = self.init_qvel + rng.uniform(low=-0.005, high=0.005, size=len(self.init_qvel))
        qvel[-4:] = 0.0
        return qpos, qvel

    def observe(self, qpos, qvel, links=None):
        n = len(qpos)
        if links is None:
            self._places = np.zeros((3, n, 3))
        else:
            self._places = np.array([links(name) for name in ("tips_arm", "object", "goal")])
        return np.concatenate([qpos[:, :7], qvel[:, :7], *self._places], axis=1)

    def evaluate(self, observation, action):
        tip, obj, goal = self._places
        near_w, dist_w, ctrl_w = self.weights
        near = -np.linalg.norm(obj - tip, axis=1) * near_w
        dist = -np.linalg.norm(obj - goal, axis=1) * dist_w
        ctrl = -np.square(action).sum(axis=1) * ctrl_w
        return dist + ctrl + near, np.zeros(len(observation), dtype=bool), \
            {"reward_dist": dist, "reward_ctrl": ctrl, "reward_near": near}


class Swimmer(ModelEnv):
    """Gymnasium's ``Swimmer-v5`` stepped by tumble, on its ``swimmer.xml``: three capsules joined by
    two hinges with motors (gear 150, controls in [-1, 1]), the first on two slides and a hinge in
    the plane, swimming in the file's fluid (``<option density="4000" viscosity="0.1">``: MuJoCo's
    inertia-box model, ``tumble.Fluid``, which ``load_mjcf`` reads); timestep 0.01 s, ``frame_skip``
    4. Observation (8,): qpos without the two slides (v5's ``exclude_current_positions_from_
    observation=True``; False keeps them), then qvel. Reward: ``forward_reward_weight`` x the x speed
    over the step ((x after - x before) / dt) less ``ctrl_cost_weight`` x |action|^2 (1, 1e-4); never
    terminated (1000 steps an episode). Reset: qpos and qvel uniform within +-``reset_noise_scale``
    (0.1). ``info``: v5's (x and y positions and speeds, distance from the origin, the reward's two
    parts); the reset's: the positions and distance."""

    def __init__(self, *, frame_skip: int = 4, forward_reward_weight: float = 1.0, ctrl_cost_weight: float = 1e-4,
                 reset_noise_scale: float = 0.1, exclude_current_positions_from_observation: bool = True, **kwargs):
        self.forward_reward_weight = _weight(forward_reward_weight, "forward_reward_weight")
        self.ctrl_cost_weight = _weight(ctrl_cost_weight, "ctrl_cost_weight")
        self.exclude_current_positions = bool(exclude_current_positions_from_observation)
        self._xy_before = None
        super().__init__(gymnasium_asset("swimmer.xml"), frame_skip=frame_skip, reset_noise_scale=reset_noise_scale,
                         **kwargs)

    def observe(self, qpos, qvel, links=None):
        self._xy = qpos[:, :2].copy()
        position = qpos[:, 2:] if self.exclude_current_positions else qpos
        return np.concatenate([position, qvel], axis=1)

    def remember(self, qpos, qvel, links=None):
        self._xy_before = qpos[:, :2].copy()

    def evaluate(self, observation, action):
        xy = self._xy
        velocity = (xy - self._xy_before) / self.dt
        forward = self.forward_reward_weight * velocity[:, 0]
        ctrl = self.ctrl_cost_weight * np.square(action).sum(axis=1)
        info = {"x_position": xy[:, 0].copy(), "y_position": xy[:, 1].copy(),
                "distance_from_origin": np.linalg.norm(xy, axis=1), "x_velocity": velocity[:, 0].copy(),
                "y_velocity": velocity[:, 1].copy(), "reward_forward": forward, "reward_ctrl": -ctrl}
        return forward - ctrl, np.zeros(len(xy), dtype=bool), info

    def reset_info(self, qpos, qvel):
        return {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(),
                "distance_from_origin": np.linalg.norm(qpos[:, :2], axis=1)}


class _Runner(ModelEnv):
    """Gymnasium's planar runners (``HalfCheetah-v5``, ``Hopper-v5``, ``Walker2d-v5``): a body on
    the file's root joints (a slide along x, a slide along z, a hinge about y) and legs of hinges
    driven by motors, running along x on the floor. Observation: qpos without the root's x (v5's
    ``exclude_current_positions_from_observation=True``; False keeps it) then qvel, clipped to
    +-``velocity_clip`` (Hopper and Walker2d: 10; HalfCheetah: none). Reward: ``forward_reward_weight``
    x the root's x speed over the step ((x after - x before) / dt, as Gymnasium measures it), less
    ``ctrl_cost_weight`` x |action|^2, plus ``healthy_reward`` while healthy; a runner with a
    ``healthy_z_range`` is healthy while the root's z and pitch (qpos[1], qpos[2]) lie strictly
    within their ranges (and, with ``healthy_state_range``, qpos[2:] and qvel within it: the
    hopper's), and is terminated when not (``terminate_when_unhealthy``). ``info``: v5's keys."""

    velocity_clip = None
    noise = "uniform"  # the reset's qvel noise: "uniform" +-scale, or "normal" scale x N(0, 1) (the cheetah's)

    def __init__(self, asset: str, *, frame_skip: int, forward_reward_weight: float = 1.0,
                 ctrl_cost_weight: float, healthy_reward: float = 1.0, terminate_when_unhealthy: bool = True,
                 healthy_z_range=None, healthy_angle_range=None, healthy_state_range=None,
                 reset_noise_scale: float, exclude_current_positions_from_observation: bool = True, **kwargs):
        self.forward_reward_weight = _weight(forward_reward_weight, "forward_reward_weight")
        self.ctrl_cost_weight = _weight(ctrl_cost_weight, "ctrl_cost_weight")
        self.healthy_reward = _weight(healthy_reward, "healthy_reward")
        self.terminate_when_unhealthy = bool(terminate_when_unhealthy)
        self.healthy_z_range = _range(healthy_z_range, "healthy_z_range")
        self.healthy_angle_range = _range(healthy_angle_range, "healthy_angle_range")
        self.healthy_state_range = _range(healthy_state_range, "healthy_state_range")
        self.exclude_current_positions = bool(exclude_current_positions_from_observation)
        self._x_before = None
        super().__init__(gymnasium_asset(asset), frame_skip=frame_skip, reset_noise_scale=reset_noise_scale, **kwargs)

    def draw_start(self, rng):
        s = self.reset_noise_scale
        qpos = self.init_qpos + rng.uniform(low=-s, high=s, size=len(self.init_qpos))
        if self.noise == "normal":
            qvel = self.init_qvel + s * rng.standard_normal(len(self.init_qvel))
        else:
            qvel = self.init_qvel + rng.uniform(low=-s, high=s, size=len(self.init_qvel))
        return qpos, qvel

    def observe(self, qpos, qvel, links=None):
        self._state = (qpos, qvel)  # for evaluate: the root's x and z are not all in the observation
        position = qpos[:, 1:] if self.exclude_current_positions else qpos
        velocity = qvel if self.velocity_clip is None else np.clip(qvel, -self.velocity_clip, self.velocity_clip)
        return np.concatenate([position, velocity], axis=1)

    def remember(self, qpos, qvel, links=None):
        self._x_before = qpos[:, 0].copy()

    def healthy(self, qpos, qvel) -> np.ndarray:
        """(n,) bool: whether each copy is healthy (class docstring)."""
        ok = np.ones(len(qpos), dtype=bool)
        for values, bounds in ((qpos[:, 1:2], self.healthy_z_range), (qpos[:, 2:3], self.healthy_angle_range),
                               (np.concatenate([qpos[:, 2:], qvel], axis=1), self.healthy_state_range)):
            if bounds is not None:
                ok &= np.all((bounds[0] < values) & (values < bounds[1]), axis=1)
        return ok

    def evaluate(self, observation, action):
        qpos, qvel = self._state
        x_velocity = (qpos[:, 0] - self._x_before) / self.dt
        forward = self.forward_reward_weight * x_velocity
        ctrl = self.ctrl_cost_weight * np.square(action).sum(axis=1)
        info = {"x_position": qpos[:, 0].copy(), "x_velocity": x_velocity, "reward_forward": forward,
                "reward_ctrl": -ctrl}
        if self.healthy_z_range is None:
            return forward - ctrl, np.zeros(len(qpos), dtype=bool), info
        healthy = self.healthy(qpos, qvel)
        survive = healthy * self.healthy_reward
        info.update(reward_survive=survive, z_distance_from_origin=qpos[:, 1] - self.init_qpos[1])
        terminated = ~healthy if self.terminate_when_unhealthy else np.zeros(len(qpos), dtype=bool)
        return forward + survive - ctrl, terminated, info

    def reset_info(self, qpos, qvel):
        info = {"x_position": qpos[:, 0].copy()}
        if self.healthy_z_range is not None:
            info["z_distance_from_origin"] = qpos[:, 1] - self.init_qpos[1]
        return info


def _weight(value, key: str) -> float:
    """A task's weight or reward ``value`` as a float; an InputError at ``key`` unless it is a finite
    number (a bool is not)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not np.isfinite(value):
        raise InputError(f"must be a finite number, got {value!r}", key)
    return float(value)


def _range(value, key: str):
    """None, or (low, high) of two numbers with low < high (+-inf allowed)."""
    if value is None:
        return None
    try:
        low, high = (float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(f"expected (low, high), got {value!r}", key) from None
    if np.isnan(low) or np.isnan(high) or not low < high:
        raise InputError(f"expected low < high, got {value!r}", key)
    return low, high


class HalfCheetah(_Runner):
    """Gymnasium's ``HalfCheetah-v5`` stepped by tumble, on its ``half_cheetah.xml`` (14 kg, six
    motors of gear 120 to 30 on sprung, damped hinges with armature 0.1; timestep 0.01 s,
    ``frame_skip`` 5): reward the forward speed less 0.1 |action|^2, never terminated (1000 steps an
    episode); reset noise 0.1 (qvel's normal). Observation (17,). ``_Runner`` says the rest."""

    noise = "normal"

    def __init__(self, *, frame_skip: int = 5, ctrl_cost_weight: float = 0.1, reset_noise_scale: float = 0.1,
                 **kwargs):
        super().__init__("half_cheetah.xml", frame_skip=frame_skip, ctrl_cost_weight=ctrl_cost_weight,
                         reset_noise_scale=reset_noise_scale, **kwargs)


class Hopper(_Runner):
    """Gymnasium's ``Hopper-v5`` stepped by tumble, on its ``hopper.xml`` (one leg of three hinges,
    timestep 0.002 s, ``frame_skip`` 4): reward the forward speed + 1 while healthy - 1e-3
    |action|^2; healthy while z > 0.7 m, |pitch| < 0.2 rad and every other coordinate and rate
    within +-100; observation (11,), rates clipped to +-10; reset noise 5e-3. ``_Runner`` says the
    rest."""

    velocity_clip = 10.0

    def __init__(self, *, frame_skip: int = 4, ctrl_cost_weight: float = 1e-3, healthy_z_range=(0.7, np.inf),
                 healthy_angle_range=(-0.2, 0.2), healthy_state_range=(-100.0, 100.0),
                 reset_noise_scale: float = 5e-3, **kwargs):
        super().__init__("hopper.xml", frame_skip=frame_skip, ctrl_cost_weight=ctrl_cost_weight,
                         healthy_z_range=healthy_z_range, healthy_angle_range=healthy_angle_range,
                         healthy_state_range=healthy_state_range, reset_noise_scale=reset_noise_scale, **kwargs)


class Walker2d(_Runner):
    """Gymnasium's ``Walker2d-v5`` stepped by tumble, on its ``walker2d_v5.xml`` (two legs of three
    hinges, timestep 0.002 s, ``frame_skip`` 4): reward the forward speed + 1 while healthy - 1e-3
    |action|^2; healthy while 0.8 < z < 2 m and |pitch| < 1 rad; observation (17,), rates clipped
    to +-10; reset noise 5e-3. ``_Runner`` says the rest."""

    velocity_clip = 10.0

    def __init__(self, *, frame_skip: int = 4, ctrl_cost_weight: float = 1e-3, healthy_z_range=(0.8, 2.0),
                 healthy_angle_range=(-1.0, 1.0), reset_noise_scale: float = 5e-3, **kwargs):
        super().__init__("walker2d_v5.xml", frame_skip=frame_skip, ctrl_cost_weight=ctrl_cost_weight,
                         healthy_z_range=healthy_z_range, healthy_angle_range=healthy_angle_range,
                         reset_noise_scale=reset_noise_scale, **kwargs)


class Ant(_Runner):
    """Gymnasium's ``Ant-v5`` stepped by tumble, on its ``ant.xml`` (a sphere on a free joint with
    four legs of two hinges each, eight motors of gear 150; timestep 0.01 s, ``frame_skip`` 5).
    Observation (105,): qpos without x and y (the root's z, its quaternion w x y z, the hinges),
    qvel (MuJoCo's free-joint layout: the root's linear velocity in the world, its angular
    velocity in its own frame), then each body's external forces (``cfrc_ext[1:]``: 13 bodies x
    (torque, force) of their contacts, about the ant's centre of mass, clipped to
    ``contact_force_range``; ``include_cfrc_ext_in_observation=False`` leaves them off: (27,)).
    Reward: the root's x speed over the step + 1 while healthy - 0.5 |action|^2 - 5e-4 |clipped
    forces|^2; healthy while every coordinate and rate is finite and 0.2 <= z <= 1 (v5's closed
    range); reset noise 0.1 (qvel's normal). The forces are tumble's contacts' (its feet's soft
    contacts against MuJoCo's): the same definition, not the same numbers (tests/test_envs_runners.py).
    The file's margins are read (``margins``): it stands at MuJoCo's height; standing, its hips keep
    a 0.01-0.02 rad/s oscillation that MuJoCo's has not (docs/robots.md, "The ant")."""

    noise = "normal"
    # its geoms' and floor's margins (0.01 each): MuJoCo's ant stands on them, its feet 2 cm above the
    # floor (torso 0.3825 m; tumble's without them 0.3626)
    margins = True

    def __init__(self, *, frame_skip: int = 5, ctrl_cost_weight: float = 0.5, contact_cost_weight: float = 5e-4,
                 healthy_z_range=(0.2, 1.0), contact_force_range=(-1.0, 1.0), reset_noise_scale: float = 0.1,
                 include_cfrc_ext_in_observation: bool = True, **kwargs):
        self.contact_cost_weight = _weight(contact_cost_weight, "contact_cost_weight")
        self.contact_force_range = _range(contact_force_range, "contact_force_range")
        self.include_cfrc_ext = bool(include_cfrc_ext_in_observation)
        super().__init__("ant.xml", frame_skip=frame_skip, ctrl_cost_weight=ctrl_cost_weight,
                         healthy_z_range=healthy_z_range, reset_noise_scale=reset_noise_scale, **kwargs)

    def observe(self, qpos, qvel, links=None):
        self._state = (qpos, qvel)
        lo, hi = self.contact_force_range
        n = len(qpos)
        forces = np.zeros((n, 13, 6)) if links is None else links.external_forces()
        self._forces = np.clip(forces, lo, hi).reshape(n, -1)
        position = qpos[:, 2:] if self.exclude_current_positions else qpos
        parts = [position, qvel] + ([self._forces] if self.include_cfrc_ext else [])
        return np.concatenate(parts, axis=1)

    def remember(self, qpos, qvel, links=None):
        self._xy_before = qpos[:, :2].copy()

    def healthy(self, qpos, qvel):
        low, high = self.healthy_z_range
        finite = np.all(np.isfinite(qpos), axis=1) & np.all(np.isfinite(qvel), axis=1)
        return finite & (low <= qpos[:, 2]) & (qpos[:, 2] <= high)

    def evaluate(self, observation, action):
        qpos, qvel = self._state
        xy_velocity = (qpos[:, :2] - self._xy_before) / self.dt
        forward = self.forward_reward_weight * xy_velocity[:, 0]
        healthy = self.healthy(qpos, qvel)
        survive = healthy * self.healthy_reward
        ctrl = self.ctrl_cost_weight * np.square(action).sum(axis=1)
        contact = self.contact_cost_weight * np.square(self._forces).sum(axis=1)
        info = {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(),
                "distance_from_origin": np.linalg.norm(qpos[:, :2], axis=1), "x_velocity": xy_velocity[:, 0],
                "y_velocity": xy_velocity[:, 1], "reward_forward": forward, "reward_ctrl": -ctrl,
                "reward_contact": -contact, "reward_survive": survive}
        terminated = ~healthy if self.terminate_when_unhealthy else np.zeros(len(qpos), dtype=bool)
        return forward + survive - ctrl - contact, terminated, info

    def reset_info(self, qpos, qvel):
        return {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(),
                "distance_from_origin": np.linalg.norm(qpos[:, :2], axis=1)}


class _Humanoid(_Runner):
    """Gymnasium's humanoids (``Humanoid-v5``, ``HumanoidStandup-v5``): a torso on a free joint,
    17 motors on hinges (abdomen, hips, knees, shoulders, elbows) with springs, dampers and
    armature, 13 bodies; timestep 0.003 s, ``frame_skip`` 5; reset noise 0.01 (uniform, qpos and
    qvel). Observation (348,): qpos without x and y (22), qvel (23), then MuJoCo's derived
    quantities of the present state, each leaving out the world: ``cinert[1:]`` (13 x 10: each
    body's inertia about the humanoid's centre of mass, its m d and m; ``_Copies.com_inertia``),
    ``cvel[1:]`` (13 x 6: angular velocity, then the velocity of its point at the centre of mass;
    ``com_velocity``), ``qfrc_actuator[6:]`` (17: the motors' torques, gear x the clipped control;
    ``actuator_forces``) and ``cfrc_ext[1:]`` (13 x 6: its contacts' torque about the centre of
    mass and force; ``external_forces``); ``include_cinert_in_observation`` and its three
    siblings leave each out. Gymnasium reads these after ``mj_step``, which computed them before
    its last integration (of the state up to a step before the qpos beside them: measured 0.06
    rad/s on cvel); tumble's are the observed state's own. ``info`` adds the fixed tendons'
    ``tendon_length`` and ``tendon_velocity`` ((2,) each: the hips' and knees' couplings, which
    drive nothing). The file's geom margins (0.001 m) are read, as MuJoCo rests on them."""

    margins = True

    def __init__(self, asset: str, *, include_cinert_in_observation: bool = True,
                 include_cvel_in_observation: bool = True, include_qfrc_actuator_in_observation: bool = True,
                 include_cfrc_ext_in_observation: bool = True, **kwargs):
        self.include = tuple(bool(v) for v in (include_cinert_in_observation, include_cvel_in_observation,
                                                include_qfrc_actuator_in_observation,
                                                include_cfrc_ext_in_observation))
        super().__init__(asset, **kwargs)
        kin = self.robot.kinematics
        # MuJoCo's fixed tendons: length sum coef q, velocity sum coef q' (term by term, in the file's
        # order: a matrix product's bits would depend on how many copies are stacked)
        self._tendons = [[(kin.by_name[joint].qpos.start, kin.by_name[joint].qvel.start, float(coef))
                          for joint, coef in terms] for terms in self.robot.tendons.values()]

    def observe(self, qpos, qvel, links=None):
        if links is None:
            raise InputError("the humanoid's observation reads the copies' bodies: pass the env's links view", "links")
        self._state = (qpos, qvel)
        n = len(qpos)
        self._forces = links.external_forces().reshape(n, -1)
        self._com = links.center_of_mass()
        position = qpos[:, 2:] if self.exclude_current_positions else qpos
        parts = [position, qvel]
        for wanted, read in zip(self.include, (lambda: links.com_inertia().reshape(n, -1),
                                               lambda: links.com_velocity().reshape(n, -1),
                                               lambda: links.actuator_forces()[:, 6:], lambda: self._forces)):
            if wanted:
                parts.append(read())
        return np.concatenate(parts, axis=1)

    def tendon_info(self, qpos, qvel) -> dict:
        """{"tendon_length": (n, T) m or rad, "tendon_velocity": (n, T)}: the fixed tendons (MuJoCo's
        ``ten_length``, ``ten_velocity``) of copies at ``qpos``, ``qvel``."""
        n = len(qpos)
        length, velocity = np.zeros((n, len(self._tendons))), np.zeros((n, len(self._tendons)))
        for t, terms in enumerate(self._tendons):
            for q, v, coef in terms:
                length[:, t] += coef * qpos[:, q]
                velocity[:, t] += coef * qvel[:, v]
        return {"tendon_length": length, "tendon_velocity": velocity}

    def healthy(self, qpos, qvel):
        low, high = self.healthy_z_range
        return (low < qpos[:, 2]) & (qpos[:, 2] < high)

    def reset_info(self, qpos, qvel):
        return {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(), **self.tendon_info(qpos, qvel)}


class Humanoid(_Humanoid):
    """Gymnasium's ``Humanoid-v5`` stepped by tumble, on its ``humanoid.xml`` (``_Humanoid`` says the
    model and the observation): walk forward. Reward: 1.25 x the speed along x of the centre of
    mass over the step (Gymnasium's ``mass_center``: the file's bodies' masses) + 5 while healthy -
    0.1 |action|^2 - min(5e-7 |cfrc_ext|^2, 10); healthy while 1 < z < 2 m (the torso's),
    terminated when not. ``info``: v5's keys."""

    def __init__(self, *, frame_skip: int = 5, forward_reward_weight: float = 1.25, ctrl_cost_weight: float = 0.1,
                 contact_cost_weight: float = 5e-7, contact_cost_range=(-np.inf, 10.0), healthy_reward: float = 5.0,
                 terminate_when_unhealthy: bool = True, healthy_z_range=(1.0, 2.0), reset_noise_scale: float = 1e-2,
                 **kwargs):
        self.contact_cost_weight = _weight(contact_cost_weight, "contact_cost_weight")
        self.contact_cost_range = _range(contact_cost_range, "contact_cost_range")
        super().__init__("humanoid.xml", frame_skip=frame_skip, forward_reward_weight=forward_reward_weight,
                         ctrl_cost_weight=ctrl_cost_weight, healthy_reward=healthy_reward,
                         terminate_when_unhealthy=terminate_when_unhealthy, healthy_z_range=healthy_z_range,
                         reset_noise_scale=reset_noise_scale, **kwargs)

    def remember(self, qpos, qvel, links=None):
        self._xy_before = links.center_of_mass()[:, :2].copy()

    def evaluate(self, observation, action):
        qpos, qvel = self._state
        xy_velocity = (self._com[:, :2] - self._xy_before) / self.dt
        forward = self.forward_reward_weight * xy_velocity[:, 0]
        healthy = self.healthy(qpos, qvel)
        survive = healthy * self.healthy_reward
        ctrl = self.ctrl_cost_weight * np.square(action).sum(axis=1)
        contact = np.clip(self.contact_cost_weight * np.square(self._forces).sum(axis=1), *self.contact_cost_range)
        info = {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(), **self.tendon_info(qpos, qvel),
                "distance_from_origin": np.linalg.norm(qpos[:, :2], axis=1), "x_velocity": xy_velocity[:, 0],
                "y_velocity": xy_velocity[:, 1], "reward_survive": survive, "reward_forward": forward,
                "reward_ctrl": -ctrl, "reward_contact": -contact}
        terminated = ~healthy if self.terminate_when_unhealthy else np.zeros(len(qpos), dtype=bool)
        return forward + survive - ctrl - contact, terminated, info

    def reset_info(self, qpos, qvel):
        return {**super().reset_info(qpos, qvel), "distance_from_origin": np.linalg.norm(qpos[:, :2], axis=1)}


class HumanoidStandup(_Humanoid):
    """Gymnasium's ``HumanoidStandup-v5`` stepped by tumble, on its ``humanoidstandup.xml`` (the
    humanoid lying on its back, torso at z = 0.105 m; ``_Humanoid`` says the model and the
    observation): stand up. Reward: ``uph_cost_weight`` x the torso's z over the simulator's
    timestep (z / 0.003 s: how high, not how fast it rose) - 0.1 |action|^2 - min(0.5e-6
    |cfrc_ext|^2, 10) + 1; never terminated. (Gymnasium 1.4's code leaves ``uph_cost_weight`` out
    of its sum while its documentation multiplies by it; with the default 1 the two agree.)
    ``info``: v5's keys."""

    def __init__(self, *, frame_skip: int = 5, uph_cost_weight: float = 1.0, ctrl_cost_weight: float = 0.1,
                 impact_cost_weight: float = 0.5e-6, impact_cost_range=(-np.inf, 10.0),
                 reset_noise_scale: float = 1e-2, **kwargs):
        self.uph_cost_weight = _weight(uph_cost_weight, "uph_cost_weight")
        self.impact_cost_weight = _weight(impact_cost_weight, "impact_cost_weight")
        self.impact_cost_range = _range(impact_cost_range, "impact_cost_range")
        super().__init__("humanoidstandup.xml", frame_skip=frame_skip, ctrl_cost_weight=ctrl_cost_weight,
                         reset_noise_scale=reset_noise_scale, **kwargs)

    def evaluate(self, observation, action):
        qpos, qvel = self._state
        up = self.uph_cost_weight * qpos[:, 2] / self.timestep
        ctrl = self.ctrl_cost_weight * np.square(action).sum(axis=1)
        impact = np.clip(self.impact_cost_weight * np.square(self._forces).sum(axis=1), *self.impact_cost_range)
        info = {"x_position": qpos[:, 0].copy(), "y_position": qpos[:, 1].copy(),
                "z_distance_from_origin": qpos[:, 2] - self.init_qpos[2], **self.tendon_info(qpos, qvel),
                "reward_linup": up, "reward_quadctrl": -ctrl, "reward_impact": -impact}
        return up - ctrl - impact + 1.0, np.zeros(len(qpos), dtype=bool), info

    def reset_info(self, qpos, qvel):
        return {**super().reset_info(qpos, qvel), "z_distance_from_origin": qpos[:, 2] - self.init_qpos[2]}


class ModelVectorEnv(VectorEnv):
    """``num_envs`` copies of a ``ModelEnv`` task in one World, stepped together by one Simulator:
    Gymnasium's vector API (observations (num_envs, d), actions (num_envs, nu), rewards,
    terminations and truncations (num_envs,)) with Gymnasium's default autoreset (``NEXT_STEP``:
    the step after a copy's episode ended resets it, ignoring its action, and reports its start
    with reward 0 and its reset's info, as ``SyncVectorEnv`` does; the only autoreset mode, and no
    ``render``). Brax's and MuJoCo's MJX way, on the CPU: one compiled step for all copies
    instead of a Python loop over environments (``gymnasium.vector.SyncVectorEnv``).

    Each copy is the single environment of its seed, bit for bit: ``reset(seed=s)`` seeds copy i
    with s + i (SyncVectorEnv's rule), so copy i's episodes are those of ``env(**kwargs)`` reset
    with seed s + i and given copy i's actions (tests/test_envs.py). The copies share one world,
    stacked in one spot: those of a model that touches are kept apart by envs
    (``CollisionFilter.env``), each touching itself and the one floor.

    Args:
        env: the ``ModelEnv`` class (its task: model file, observation, reward, termination).
        num_envs: how many copies.
        max_episode_steps: a copy's episode is truncated after this many steps (None: never;
            ``gymnasium.make_vec`` passes the registered limit).
        **kwargs: the ``env`` class's arguments (``frame_skip``, ``timestep``,
            ``reset_noise_scale``, ``joint_settings``, ``contact_settings``).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, env, num_envs: int, *, max_episode_steps: int | None = None, **kwargs):
        if not (isinstance(env, type) and issubclass(env, ModelEnv)):
            raise InputError(f"expected a ModelEnv class, got {env!r}", "env")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise InputError(f"must be a whole number >= 1, got {num_envs!r}", "num_envs")
        if max_episode_steps is not None and (isinstance(max_episode_steps, bool) or
                                              not isinstance(max_episode_steps, (int, np.integer)) or
                                              max_episode_steps < 1):
            raise InputError(f"must be a whole number >= 1 or None, got {max_episode_steps!r}", "max_episode_steps")
        # the task's settings, spaces and methods, from one copy made alone (never stepped)
        self.template = env(**kwargs)
        t = self.template
        self.num_envs = int(num_envs)
        self.max_episode_steps = max_episode_steps
        self.frame_skip, self.timestep = t.frame_skip, t.timestep
        self._copies = _Copies(t.model, self.num_envs, t.timestep, kwargs.get("joint_settings"),
                               kwargs.get("contact_settings"), t.margins)
        self.world, self.sim = self._copies.world, self._copies.sim
        self.single_action_space, self.single_observation_space = t.action_space, t.observation_space
        self.action_space = batch_space(t.action_space, self.num_envs)
        self.observation_space = batch_space(t.observation_space, self.num_envs)
        self._rngs = [None] * self.num_envs
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._ended = np.zeros(self.num_envs, dtype=bool)

    @property
    def dt(self) -> float:
        """s, the time one ``step`` covers (each copy's)."""
        return self.timestep * self.frame_skip

    def _reset_copies(self, copies: list):
        """Each of ``copies`` to its start drawn from its own generator: (qpos (K, nq), qvel (K, nv))."""
        starts = [self.template.draw_start(self._rngs[i]) for i in copies]
        qpos = np.array([q for q, _ in starts]).reshape(len(copies), -1)
        qvel = np.array([v for _, v in starts]).reshape(len(copies), -1)
        self._copies.set_states(copies, qpos, qvel)
        self._elapsed[copies] = 0
        self._ended[copies] = False
        return qpos, qvel

    def reset(self, *, seed=None, options: dict | None = None):
        """Every copy back to its start: (observations (num_envs, d), info {}). ``seed``: an int (copy
        i gets seed + i), a list of num_envs ints or Nones, or None (each copy's generator goes on;
        seeded from the OS the first time, as a single environment's)."""
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed) if isinstance(seed, (list, tuple)) else None
            if seeds is None or len(seeds) != n or not all(
                    s is None or (isinstance(s, (int, np.integer)) and not isinstance(s, bool) and s >= 0) for s in seeds):
                raise InputError(f"expected an int, None or a list of {n} ints or Nones, got {seed!r}", "seed")
            seeds = [None if s is None else int(s) for s in seeds]
        super().reset(seed=seeds[0] if seeds else None)
        for i, s in enumerate(seeds):
            if s is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(s)
        qpos, qvel = self._reset_copies(list(range(n)))
        info = {}
        for key, value in self.template.reset_info(qpos, qvel).items():
            info[key], info["_" + key] = np.asarray(value), np.ones(n, dtype=bool)
        return self.template.observe(qpos, qvel, self._copies.view), info

    def step(self, actions):
        """One step of every copy (``frame_skip`` simulator steps of the one world) with ``actions``
        (num_envs, nu); the copies whose episode ended at the last step are reset instead (their
        action ignored, reward 0, neither terminated nor truncated): (observations, rewards,
        terminations, truncations, info {key: (num_envs,)}, with ``"_key"`` masks of the copies
        that report it: a copy reset here reports its reset's info, the others their step's;
        ``SyncVectorEnv``'s, bit for bit, ``_vector_info``)."""
        n = self.num_envs
        u = _check_actions(actions, n, len(self.template.actuators))
        restart = np.flatnonzero(self._ended)
        self._copies.set_controls(u)
        self.template.remember(*self._copies.state(), self._copies.view)
        self.sim.step(self.frame_skip)
        self._copies.fresh[:] = False
        # the copies to restart moved with the others (one world); their start is put back now
        starts = self._reset_copies(restart.tolist()) if len(restart) else None
        qpos, qvel = self._copies.state()
        if starts is not None:  # their observation is the start as drawn (a single env's reset's)
            qpos[restart], qvel[restart] = starts
        obs = self.template.observe(qpos, qvel, self._copies.view)
        reward, terminated, info = self.template.evaluate(obs, u)
        reward, terminated = np.array(reward, dtype=np.float64), np.array(terminated, dtype=bool)
        stepped = np.ones(n, dtype=bool)
        stepped[restart] = False
        self._elapsed[stepped] += 1
        truncated = np.zeros(n, dtype=bool) if self.max_episode_steps is None else \
            stepped & (self._elapsed >= self.max_episode_steps)
        reward[~stepped] = 0.0
        terminated &= stepped
        self._ended = terminated | truncated
        restart_info = self.template.reset_info(*starts) if starts is not None else {}
        return obs, reward, terminated, truncated, _vector_info(info, stepped, restart_info, restart)


def _vector_info(info: dict, stepped: np.ndarray, restart_info: dict, restart: np.ndarray) -> dict:
    """A vector step's info as ``SyncVectorEnv`` (NEXT_STEP) gathers its copies' ``_add_info``: each
    copy that stepped reports ``info`` (its row of each value (n, ...)), each copy restarted
    (``restart``, its rows of ``restart_info`` (K, ...)) its single environment's reset info; a key's
    array holds zeros where a copy does not report it, and ``"_key"`` marks the copies that do. The
    keys come in the order the copies first report them (copy 0's keys first), a key that no copy
    reports is left out, and a key's dtype is that of its first reporting copy's value (as a
    single environment returns it: a Python number, or an array)."""
    n = len(stepped)
    step_keys = list(info) if stepped.any() else []
    reset_keys = list(restart_info) if len(restart) else []
    first_restarted = len(restart) > 0 and restart[0] == 0
    keys = list(dict.fromkeys(reset_keys + step_keys if first_restarted else step_keys + reset_keys))
    at = np.full(n, -1)  # each restarted copy's row in restart_info
    at[restart] = np.arange(len(restart))
    out = {}
    for key in keys:
        mask = np.zeros(n, dtype=bool)
        if key in step_keys:
            mask |= stepped
        if key in reset_keys:
            mask[restart] = True
        j = int(np.argmax(mask))  # the first copy that reports it: its value as a single env gives it
        source, row = (info[key], j) if stepped[j] else (restart_info[key], at[j])
        first = _one(np.asarray(source)[row:row + 1])
        array = np.zeros((n, *np.shape(first)), dtype=np.asarray(first).dtype)
        if key in step_keys:
            array[stepped] = np.asarray(info[key])[stepped]
        if key in reset_keys:
            array[restart] = np.asarray(restart_info[key])
        out[key], out["_" + key] = array, mask
    return out


# the ids tumble adds, with Gymnasium's episode limits and reward thresholds for its own v5 tasks
TASKS = (("InvertedPendulum", 1000, 950.0), ("Reacher", 50, -3.75), ("InvertedDoublePendulum", 1000, 9100.0),
         ("Pusher", 100, 0.0), ("Swimmer", 1000, 360.0), ("HalfCheetah", 1000, 4800.0), ("Hopper", 1000, 3800.0),
         ("Walker2d", 1000, None), ("Ant", 1000, 6000.0), ("Humanoid", 1000, None), ("HumanoidStandup", 1000, None))


def _register():
    """``gymnasium.make("tumble/NAME-v5")`` and ``gymnasium.make_vec(..., vectorization_mode=
    "vector_entry_point")`` (a ``ModelVectorEnv`` of the task) for each of ``TASKS``."""
    for name, steps, threshold in TASKS:
        if f"tumble/{name}-v5" not in gymnasium.registry:
            gymnasium.register(f"tumble/{name}-v5", entry_point=f"tumble.envs:{name}",
                               vector_entry_point=functools.partial(ModelVectorEnv, globals()[name]),
                               max_episode_steps=steps, reward_threshold=threshold)


_register()
