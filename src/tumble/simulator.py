"""Simulator: the step pipeline and the frame loop (course Algorithm 5, as ERRATA 3 corrects it).

One step of free motion is, in order:

1. ``accumulate_forces``     gravity, drag, wind, springs, constant and point forces, user callables
2. ``integrate_free_motion`` the chosen integrator advances x, q or R, P, L by h
3. ``project_orientation``   q back to unit length, or R back onto SO(3) (ERRATA 5)

(the contact stages of DESIGN.md join after 2 when collisions land). Without
user callables the whole run between two frames is one compiled call
(``integrators.step_kernel``); with them, the same kernels are called stage by
stage from Python with the callables in between, in the same order.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from pathlib import Path

import numpy as np

from . import checks
from . import integrators as K
from .errors import InputError, SimulationError
from .collision.sensor import SensorLog
from .buoyancy import apply_buoyancy
from .forces import Explosion, Impulse, Switch, force_edit_count
from .joints import P_ARMATURE
from .joints import edit_count as _joint_edit_count
from .math3d import quat_to_matrix
from .kinematic import drive_paths, touched_by_kinematic
from .recording import RunResult, _first_frame_notice, _progress_bar, _Recorder
from .solver.contact import SoftStepSettings
from .solver.contact_events import ContactEventLog
from .solver.island import SleepState
from .solver.soft_step import SoftStep, advance_kinematic_kernel
from .trajectory import Trajectory
from .world import Scratch, World


def steps_between(interval: float, dt: float, what: str) -> int:
    """Whole number of steps of dt in ``interval`` (within 1e-6 of a step), or InputError."""
    n = interval / dt
    k = int(round(n))
    if k < 1 or abs(n - k) > 1e-6 * max(1.0, n):
        raise InputError(f"{what} ({interval:g} s) must be a whole number of steps dt = {dt:g} s", "simulation.dt")
    return k


# NOTE: a run of more integrator steps than this is refused before it starts (InputError naming
# the key that makes it so many): at about 17 us a step for one body (the cheapest step
# measured) 1e9 steps are more than 4 hours of computing, and a typo (substeps = 1e12,
# dt = 1e-300) otherwise ran for ever while ``tumble validate`` said ok. The longest run of
# the examples and the tests takes 80 000 steps (examples/joints/double_pendulum.toml: 10 s at
# dt 1/1000 x 8 substeps), four orders of magnitude below.
MAX_RUN_STEPS = 10**9


def _as_float(value) -> float:
    try:
        return float(value)
    except OverflowError:  # an integer beyond the float range
        return math.inf


def check_step_count(duration, frame_rate, dt, substeps, key_prefix: str = "simulation."):
    """InputError when a run of ``duration`` s at ``frame_rate`` with steps ``dt`` of ``substeps``
    integrator steps each would take more than ``MAX_RUN_STEPS`` integrator steps; the key named is
    that of the largest factor (the frames: ``duration``, the steps a frame: ``dt``, ``substeps``).
    The arguments are positive numbers already checked."""
    with np.errstate(over="ignore"):
        frames = _as_float(duration) * _as_float(frame_rate)
        per_frame = (1.0 / _as_float(frame_rate)) / _as_float(dt)
        sub = _as_float(substeps)
        total = frames * per_frame * sub
    if not total > MAX_RUN_STEPS and math.isfinite(total):
        return
    factors = (("duration", frames), ("dt", per_frame), ("substeps", sub))
    key = max(factors, key=lambda f: f[1])[0]
    fix = {"duration": "shorten the run", "dt": "use a larger dt", "substeps": "use fewer substeps"}[key]
    amount = f"about {total:.3g}" if math.isfinite(total) else "more than 1e308"
    raise InputError(f"the run would take {amount} integrator steps ({_g(_as_float(duration))} s at {_g(_as_float(frame_rate))} "
                     f"frames a second, {_g(per_frame)} steps of dt a frame, {_g(sub)} substeps a step), more than the limit "
                     f"of {MAX_RUN_STEPS:.0e}; {fix}", key_prefix + key)


def _g(v: float) -> str:
    return f"{v:.6g}" if math.isfinite(v) else "inf"


def _whole_number(value, key: str, minimum: int, floats: bool = True) -> int:
    """``value`` as an int >= ``minimum`` (an int, a NumPy integer, or with ``floats`` a whole float),
    else an InputError keyed ``key``."""
    ok = not isinstance(value, (bool, np.bool_)) and (
        isinstance(value, (int, np.integer))
        or (floats and isinstance(value, (float, np.floating)) and math.isfinite(value) and float(value).is_integer()))
    if not ok or int(value) < minimum:
        raise InputError(f"must be a whole number >= {minimum}, got {value!r}", key)
    return int(value)


def _positive_number(value, key: str) -> float:
    """``value`` as a positive finite float, else an InputError keyed ``key`` (the scene file's wording)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"expected a number, got {value!r}", key)
    v = _as_float(value)
    if not math.isfinite(v):
        raise InputError(f"must be a finite number, got {value!r}" if isinstance(value, (float, np.floating))
                         else "must be a finite number, got an integer beyond the float range", key)
    if v <= 0:
        raise InputError(f"must be positive, got {v:g}", key)
    return v


class Simulator:
    """Steps a ``World`` in time and records frames.

    Args:
        world: the bodies and forces.
        dt: internal step, s (default 1/240). For ``rk45``/``dop853`` it is
            only the interval at which impulses can act; their own step is adaptive.
        integrator: one of ``integrators.INTEGRATOR_IDS`` (default "rk4":
            fourth order, 2e-8 rad after 10 s of a tumbling box at 1/240 s;
            see docs/integrators.md).
        substeps: each step is made of this many integrator steps of dt/substeps.
        rtol, atol: tolerances of the adaptive integrators (defaults 1e-10, 1e-12).
        max_energy_growth: a run stops (SimulationError) when its total energy
            rises past E0 + (max_energy_growth - 1) * scale (``checks.energy_bound``;
            default 1e6, >= 1).

    controller: ``f(sim)``, called before every step with the world at the step's start
        (``sim.world``, its time ``sim.world.t``): it may set velocities, apply impulses,
        change motor speeds, kinematic targets or body types (MuJoCo's control callback, the
        body of a PyBullet loop); it must not add bodies (an InputError keyed ``controller``:
        add them between calls). Runs with one go one step at a time. Settable later as
        ``sim.controller``.

    With ``TUMBLE_VALIDATE=1`` in the environment, ``checks.validate_world`` runs
    after every stage of every step (the stage-by-stage path; same results, slower).
    """

    def __init__(self, world: World, dt: float = 1.0 / 240.0, integrator: str = "rk4", substeps: int = 1, rtol: float = 1e-10, atol: float = 1e-12,
                 max_energy_growth: float = checks.MAX_ENERGY_GROWTH, contact_settings: SoftStepSettings | None = None,
                 record_contacts: bool = False, joint_settings=None, record_joints: bool = False,
                 contact_events: bool = False, controller=None):
        if integrator not in K.INTEGRATOR_IDS:
            names = ", ".join(K.INTEGRATOR_IDS)
            raise InputError(f"unknown integrator {integrator!r} (expected one of {names})", "simulation.integrator")
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            raise InputError(f"expected a number, got {dt!r}", "simulation.dt") from None
        if not math.isfinite(dt) or dt <= 0:
            raise InputError(f"must be a positive finite number, got {dt}", "simulation.dt")
        substeps = _whole_number(substeps, "simulation.substeps", 1)
        if substeps > MAX_RUN_STEPS:
            raise InputError(f"must be at most {MAX_RUN_STEPS:.0e} (the most integrator steps a run may take), got {substeps}",
                             "simulation.substeps")
        rtol = _positive_number(rtol, "simulation.rtol")
        atol = _positive_number(atol, "simulation.atol")
        if contact_settings is not None and not isinstance(contact_settings, SoftStepSettings):
            raise InputError(f"expected a tumble.solver.contact.SoftStepSettings or None, got {contact_settings!r}", "contact_settings")
        if joint_settings is not None:
            from .solver.joints import JointSettings

            if not isinstance(joint_settings, JointSettings):
                raise InputError(f"expected a tumble.solver.joints.JointSettings or None, got {joint_settings!r}", "joint_settings")
        self.world = world
        self.dt = dt
        self.integrator = integrator
        self.integrator_id = K.INTEGRATOR_IDS[integrator]
        self.substeps = substeps
        self.rtol = rtol
        self.atol = atol
        # steps of dt since t = 0: a Simulator on a world that has already run goes on from its time
        self.step_index = int(round(world.t / dt))
        # lowest_separation: m, the lowest contact separation at any step of the run (None: no
        # contact point yet); ``largest_penetration`` reads it
        self.stats = {"steps": 0, "derivative_evaluations": 0, "lowest_separation": None}
        try:
            self.max_energy_growth = float(max_energy_growth)
        except (TypeError, ValueError):
            raise InputError(f"expected a number, got {max_energy_growth!r}", "simulation.max_energy_growth") from None
        if not self.max_energy_growth >= 1.0:
            raise InputError(f"must be a number >= 1, got {max_energy_growth!r}", "simulation.max_energy_growth")
        if joint_settings is not None and getattr(joint_settings, "position_iterations", 0) != 0:
            # NOTE: the NGS projection moves x, q, R apart from the packed state the soft step
            # integrates, and it made energy worse where measured (docs/joints.md): refused here
            # rather than ignored without a word.
            raise InputError("the Simulator's step does not project joint positions; use 0 (the projection runs "
                             "only in tumble.solver.joints.step_with_joints)", "joint_settings.position_iterations")
        self.validate = checks.validation_enabled()
        self.energy_reference = None  # [E0 J, scale J, impulses applied] of the current run
        self.checkpoint_run = None  # the ``run`` data of the checkpoint this simulator was loaded from
        self.contact_settings = contact_settings
        self.soft_step = None  # SoftStep: collision pipeline + contact solver, made on first use
        self.sleep = None  # solver.island.SleepState, made on the first step with contacts
        self.record_contacts = bool(record_contacts)
        if joint_settings is None and (world.exact_joints or any(
                j.bound is not None and j.bound.param[P_ARMATURE] > 0.0 for j in getattr(world, "joints", ()))):
            # light virtual links between joints (tumble.mjcf): Gauss-Seidel's soft rows leave errors of
            # tenths of a radian there (measured against MuJoCo), the exact tree solve converges; the
            # same for armature and gears (World.add_joint; an armature set on a record after it too)
            from .solver.joints import ACCURATE

            joint_settings = ACCURATE
        self.joint_settings = joint_settings  # tumble.solver.joints.JointSettings, or None for its defaults
        self.record_joints = bool(record_joints)
        # tumble.joints.edit_count() when this simulator last took the joint records' edits
        # (``_take_joint_edits``); the edits before it was made have nothing here to wake
        self._joint_edits_seen = _joint_edit_count()
        self._force_edits_seen = force_edit_count()  # the same for the force records (_take_force_edits)
        # how many of World.type_changes this simulator has taken (_take_type_changes)
        self._type_changes_seen = len(getattr(world, "type_changes", ()))
        # begin and end touch events, step by step, when asked for (solver.contact_events)
        self._event_log = ContactEventLog() if contact_events else None
        self._sensor_log = None  # collision.sensor.SensorLog, made on the first step of a world with a sensor
        if controller is not None and not callable(controller):
            raise InputError(f"expected a function f(sim), got {controller!r}", "controller")
        self.controller = controller

    # ------------------------------------------------------------------ stepping
    def step(self, count: int = 1):
        """Advance the world by ``count`` steps of dt (applying due impulses first).

        ``count`` is a whole number >= 0 (an int or a NumPy integer; 0 does nothing); anything else,
        or more than ``MAX_RUN_STEPS`` integrator steps in one call, is an InputError keyed ``count``.

        Raises:
            SimulationError: the state went non-finite (``run``'s check, once at the end of the call;
                its stage found by replaying the call stage by stage); the
                World is back where the call started. Without it a step loop (MuJoCo's and
                PyBullet's way of driving a robot) went on silently with NaN: PyBullet's thrower
                model, its 1e-9 kg fingertips in contact, was NaN from step 36 on (measured).
        """
        count = _whole_number(count, "count", 0, floats=False)
        if count * self.substeps > MAX_RUN_STEPS:
            raise InputError(f"{count} steps of {self.substeps} substeps would be more than the limit of {MAX_RUN_STEPS:.0e} "
                             "integrator steps in one call", "count")
        w = self.world
        Y = w.pack()
        types = self._type_mark()
        # the World's arrays keep the start until unpack, unless a controller sees every step or a
        # body's type may change (a path that lets go unpacks the state there): then a copy
        start = None if self.controller is None and types is None else Y.copy()
        marks = (self.step_index, set(w.applied_impulses), dict(self.stats))
        scratch = Scratch(w.body_count, w.state_size)
        try:
            Y = self._advance_steps(Y, count, scratch)
            # PERF: one sum is the cheap test (a NaN or inf anywhere makes it non-finite), the full
            # check only then: step(1) of one body cost 25 us with the full check, 17.4 without
            if not math.isfinite(float(Y.sum())):
                problem = checks.state_problem(Y, w.layout, w.moving)
                if problem is not None:
                    Y0 = w.pack() if start is None else start
                    self._put_types_back(types)  # the replay starts from the call's start
                    raise self._diagnose((Y0.copy(),) + marks, count, problem)
        except BaseException:  # as run's frames: a blow-up, an interrupt, a bad user force
            self._put_types_back(types)
            self._restore((w.pack() if start is None else start,) + marks)
            raise
        w.unpack(Y)

    def _type_mark(self):
        """The bodies' types now (``snapshot.capture_types``) when the coming steps may change them
        (a controller, a keyframed path that lets its body go), else None: a call that fails puts
        the world back where it started, its bodies' types too (``_put_types_back``)."""
        w = self.world
        if self.controller is None and not any(p.release for p in w.paths) and not self._switches_to_come():
            return None
        from .snapshot import capture_types

        return capture_types(w)

    def _put_types_back(self, mark):
        """Put back the types of a ``_type_mark`` (None: nothing to do)."""
        if mark is not None:
            from .snapshot import put_types_back

            put_types_back(self.world, *mark)

    def _advance_steps(self, Y, count: int, scratch):
        """``_advance`` by ``count`` steps; with a controller, one step at a time, the controller
        called before each with the world at the step's start (unpacked from Y, packed again)."""
        if self.controller is None:
            return self._advance(Y, count, scratch)
        w = self.world
        n = w.body_count
        for _ in range(count):
            w.unpack(Y)
            w.t = self.step_index * self.dt
            self.controller(self)
            if w.body_count != n:
                # a call's arrays (its scratch, a run's frames) are sized for the bodies it began
                # with: a spawn inside it failed on a NumPy broadcast deep in the step
                raise InputError(f"the controller added a body at t = {w.t:g} s, inside a run or a step(count) call: "
                                 "add bodies between calls (a loop of sim.step(), or a controller that calls "
                                 "nothing but sets and pushes)", "controller")
            Y = w.pack()
            Y = self._advance(Y, 1, scratch)
        return Y

    def _advance(self, Y: np.ndarray, count: int, scratch: Scratch, check=None) -> np.ndarray:
        """Advance the packed state Y by ``count`` steps, splitting at impulse times.

        ``check(stage, t, Y=..., F=..., T=...)``, when given (or when ``TUMBLE_VALIDATE=1``),
        is called after every stage and forces the stage-by-stage path.
        """
        if check is None and self.validate:
            check = self._validate_stage
        end = self.step_index + count
        floating = bool(self.world.tables.buoyancy)
        while self.step_index < end:
            if self.world.paths:
                Y = self._release_due_paths(Y)
            if self.world.switch_count:  # (no call per step in a world without a switch)
                Y = self._switch_due_bodies(Y)
            if self._type_changes_seen != len(self.world.type_changes):
                Y = self._take_type_changes(Y)
            self._apply_due_impulses(Y)
            if check is not None:
                check("apply_impulses", self.step_index * self.dt, Y=Y)
            if self.world.forces or self.world.paths:  # (the impulses are among the forces)
                nxt = min([end] + [k for k in self._impulse_steps() if k > self.step_index]
                          + [k for k, _ in self._release_steps() if k > self.step_index])
            else:  # PERF: no list of nothing to make, every step of a world without forces or paths
                nxt = end
            if floating:
                # buoyancy and drag for this step (at the mid-step pose foreseen from its start:
                # tumble.buoyancy), held over it; so one step at a time
                nxt = self.step_index + 1
                apply_buoyancy(self.world, Y, self.dt)
            n = nxt - self.step_index
            if self._contact_on():
                Y = self._advance_with_contacts(Y, n, scratch, check)
            elif self.world.kinematic.any():
                # one step at a time: springs and callables on the dynamic bodies see the
                # kinematic ones where they are at the start of each step
                kinematic = self.world.kinematic_moving
                for k in range(n):
                    self.step_index = nxt - n + k
                    self._drive_paths(Y)
                    Y = self._advance_free(Y, 1, scratch, check, parallel=False)
                    self._advance_kinematic(Y, kinematic, scratch)
            else:
                Y = self._advance_free(Y, n, scratch, check)
            self.step_index = nxt
            self.world.t = self.step_index * self.dt
            self.stats["steps"] += n * self.substeps
        return Y

    def _kinematic_substeps(self) -> int:
        """Substeps of a kinematic body's motion per step: the soft step's (``substeps`` x the
        contact settings' substeps) whether or not it runs, so its path is one sequence of bits."""
        settings = self.contact_settings or SoftStepSettings()
        return self.substeps * int(settings.substeps)

    def _drive_paths(self, Y):
        """The path bodies' velocities for the step from ``step_index`` (tumble.kinematic)."""
        if self.world.paths:
            drive_paths(self.world, Y, self.step_index * self.dt, self.dt)

    def _advance_kinematic(self, Y, kinematic, scratch):
        """One step dt of the ``kinematic`` (N,) bool bodies at their velocities (soft_step.
        advance_kinematic_kernel): x += h v, the exact turn of omega h, in the soft step's substeps."""
        if kinematic.any():
            n = self._kinematic_substeps()
            w = self.world
            advance_kinematic_kernel(w.layout_id, Y, kinematic, w.kinematic_v, w.kinematic_omega, self.dt / n, n,
                                     scratch.R)

    def _advance_free(self, Y, n, scratch, check=None, parallel: bool = True):
        """n steps of the chosen integrator for the moving bodies (no contact), from ``step_index``.
        ``parallel=False`` keeps the compiled path on one thread (for single steps between collisions)."""
        if self.integrator_id in K.ADAPTIVE:
            Y = self._advance_adaptive(Y, n)
            if check is not None:
                check(f"integrate_free_motion ({self.integrator}, between steps {self.step_index} and {self.step_index + n})",
                      (self.step_index + n) * self.dt, Y=Y)
        elif self.world.tables.custom or check is not None:
            self._advance_stagewise(Y, n, scratch, check)
        else:
            self._advance_compiled(Y, n, scratch, parallel)
        return Y

    # ------------------------------------------------------------------ contact
    def _contact_on(self) -> bool:
        """The soft step runs when two shapes can touch (collisions on) or the world has joints."""
        if not getattr(self.world, "collisions", True) and not getattr(self.world, "joints", None):
            return False
        if self.soft_step is None:
            self.soft_step = self._new_soft_step()
        if self.soft_step.has_collisions() or self.soft_step.has_joints():
            return True
        # Nothing can touch now, but a body asleep or a sensor's visitor left from when something
        # could (a filter changed, a body disabled or made fixed) needs one more step of contacts:
        # the free flight below neither wakes sleepers (it moved them asleep, their kept contacts
        # reported) nor ends sensor overlaps (the zone kept its visitor, no end event). Found by an
        # audit of the scene API, session 42.
        sleeping = self.sleep is not None and not self.sleep.awake.all()
        visited = self._sensor_log is not None and len(self._sensor_log.pairs) > 0
        return sleeping or visited

    def _new_soft_step(self) -> SoftStep:
        """The contact and joint stages for this world and settings (made on the first step, and
        anew by ``restore_state``)."""
        return SoftStep(self.world, self.contact_settings, self.joint_settings)

    def _advance_with_contacts(self, Y, n, scratch, check=None):
        """n steps: collide; bodies with contacts take the soft step, the others the chosen integrator.

        Sleeping (``world.sleeping``, on by default; ``solver.island``): islands at rest for
        ``TIME_TO_SLEEP`` stop moving and cost nothing; they wake whole when an awake body
        touches them. Call order per step (island.py): mask the sleepers out of ``moving`` (and
        the broadphase), collide, update the sleep state; if an island woke or fell asleep,
        mask again and collide again (rare).

        NOTE: the two groups are stepped one after the other (contact bodies first); forces
        that couple them (springs, callables) see the other group at the start of the step.
        """
        w = self.world
        soft = self.soft_step
        moving = w.moving
        all_moving = moving.copy()
        table = soft.pipeline.refresh()
        sleep = self._sleep_state()
        if self._joint_edits_seen != _joint_edit_count():
            self._take_joint_edits()
        if self._force_edits_seen != force_edit_count():
            self._take_force_edits()
        if w.wake_requests:  # bodies the user moved, pushed or placed since the last step
            if sleep is not None:
                sleep.resize(w.body_count)
                sleep.wake(sorted(w.wake_requests))
            w.wake_requests.clear()
        kinematic = w.kinematic_moving
        movers = kinematic if kinematic.any() else None
        sensors = self._sensors()
        first = self.step_index
        try:
            for k in range(n):
                self.step_index = first + k
                t = self.step_index * self.dt
                self._drive_paths(Y)
                Y_start = Y.copy() if sensors is not None else None  # for the sensors' passes
                if sleep is not None:
                    sleep.resize(w.body_count)
                    moving[:] = all_moving & sleep.awake
                    table.body_moving[:] = moving
                active = soft.collide(Y, t, self.dt)
                if sleep is not None:
                    c = soft.contacts
                    touched = None if movers is None else touched_by_kinematic(w, soft, movers, sleep.awake, all_moving)
                    driven = None if soft.joints is None else soft.joints.effort_bodies(w.body_count)
                    if driven is not None:  # joints applying a torque or force keep their bodies awake
                        touched = driven if touched is None else touched | driven
                    sleep.update(w, Y, c.contact_body_a, c.contact_body_b, self.dt, moving=all_moving,
                                 also_awake=touched)
                    if sleep.woke.any() or sleep.fell_asleep.any():
                        # an island asleep is no longer collided, but still rests on its contacts:
                        # kept from this collide, with the last step's impulses (SleepState.keep_resting)
                        sleep.keep_resting(soft.resting_fields(sleep.fell_asleep, self.dt) if sleep.fell_asleep.any() else None,
                                           all_moving)
                        moving[:] = all_moving & sleep.awake
                        table.body_moving[:] = moving
                        active = soft.collide(Y, t, self.dt)
                c = soft.contacts
                if c.contact_count:  # the deepest contact of the step, before its impulses (largest_penetration)
                    low = float(c.contact_separation.min())
                    seen = self.stats.get("lowest_separation")
                    if seen is None or low < seen:
                        self.stats["lowest_separation"] = low
                if check is not None:
                    check("collide_pairs", t, Y=Y)
                if active.any():
                    # the moving kinematic bodies move in the soft step's substeps, with the bodies they push
                    soft.step(Y, t, self.dt, self.substeps, check, kinematic=kinematic)
                    moving &= ~active
                else:
                    self._advance_kinematic(Y, kinematic, scratch)
                if moving.any():
                    # PERF: one step at a time here, so the parallel kernel's thread start-up would cost more than it saves
                    Y = self._advance_free(Y, 1, scratch, check, parallel=False)
                moving[:] = all_moving
                if self._event_log is not None:
                    stepped = all_moving & sleep.awake if sleep is not None else all_moving
                    self._event_log.after_step(soft, stepped, (self.step_index + 1) * self.dt)
                if sensors is not None:
                    sensors.update(w, soft.pipeline, Y, (self.step_index + 1) * self.dt, *soft.pipeline.user_filters(),
                                   Y0=Y_start)
        finally:
            moving[:] = all_moving
            table.body_moving[:] = all_moving
            self.step_index = first
        return Y

    def _sensors(self):
        """The ``SensorLog`` when the world has a sensor (made on first use), else None."""
        if self._sensor_log is None and self.world.sensor.any():
            self._sensor_log = SensorLog()
        return self._sensor_log

    def _sensing(self) -> bool:
        """Whether the sensors are detected: the world has one and collisions are on."""
        return bool(self.world.sensor.any()) and self._contact_on()

    def _sense_now(self):
        """The sensors' overlaps at the world's current state (the start of a run: a body that
        starts inside a sensor begins there, at that time); nothing without sensors."""
        if self._sensing():
            soft = self.soft_step
            self._sensors().update(self.world, soft.pipeline, self.world.pack(), self.world.t,
                                   *soft.pipeline.user_filters())

    def sensor_frame(self) -> np.ndarray:
        """(K,) float: how many bodies overlap each of the K sensors (body order) now: the
        trajectory's per-frame ``sensor_visitors``."""
        log = self._sensor_log
        return np.zeros(int(self.world.sensor.sum())) if log is None else log.counts(self.world)

    def sensor_events(self):
        """The sensor begin and end events since the last call (``collision.sensor.SensorEvents``:
        (sensor, visitor) body pairs that began or stopped overlapping, at the end of which step)."""
        log = self._sensors()
        if log is None:
            raise InputError("the world has no sensor (add_body(..., sensor=True))", "sensor")
        return log.drain()

    def sensor_overlaps(self, sensor=None) -> np.ndarray:
        """The bodies overlapping the sensors at the end of the last step: (K, 2) int64 (sensor,
        visitor) rows, sorted; with ``sensor`` (a Body, name or index), the visitors' (V,) indices."""
        log = self._sensors()
        if log is None:
            raise InputError("the world has no sensor (add_body(..., sensor=True))", "sensor")
        if sensor is None:
            return log.pairs.copy()
        i = self.world.index_of(sensor)
        if not self.world.sensor[i]:
            raise InputError(f"body {self.world.names[i]!r} is not a sensor", "sensor")
        return log.pairs[log.pairs[:, 0] == i, 1].copy()

    def _release_steps(self) -> list:
        """[(step, path)]: the keyframed paths that let their body go (``KeyframePath.release``)
        and the first step starting at or after their last key."""
        return [(int(math.ceil(p.times[-1] / self.dt - 1e-9)), p) for p in self.world.paths if p.release]

    def _release_due_paths(self, Y: np.ndarray) -> np.ndarray:
        """Make the bodies of the paths due to release at this step dynamic (``World.set_body_type``:
        the body goes on at the velocity of the path's last step, which brought it to the last
        key). Y (N, W) is the state now; returned as the world holds it after."""
        due = [p for k, p in self._release_steps() if k <= self.step_index]
        if not due:
            return Y
        w = self.world
        w.unpack(Y)
        for path in due:
            w.set_body_type(path.body, "dynamic")
        return w.pack()

    def _switches_to_come(self) -> list:
        """Indices into ``world.forces`` of the ``Switch`` records not applied yet, in the order
        they were added (none looked for in a world without one: ``World.switch_count``)."""
        w = self.world
        if not w.switch_count:
            return []
        return [k for k, f in enumerate(w.forces) if isinstance(f, Switch) and k not in w.applied_impulses]

    def _switches_due(self) -> list:
        """``_switches_to_come`` due at this step (their time reached), in the order they were added."""
        w = self.world
        return [k for k in self._switches_to_come() if self._impulse_step(w.forces[k]) <= self.step_index]

    def shown_disabled(self) -> np.ndarray:
        """(N,) bool: the bodies out as a frame recorded now shows them: ``World.disabled`` with
        the ``Switch`` records due at this step taken as done (the next step applies them before
        anything moves). NOTE: why: a body with ``enable_at = 1.0`` started falling at t = 1.0
        but was drawn hidden in the frame at 1.0 and appeared one frame late (the frame records
        the world before the switch's step; an audit of the exports, session 41)."""
        w = self.world
        due = self._switches_due()
        if not due:
            return w.disabled
        flags = w.disabled.copy()
        for k in due:
            flags[w.index_of(w.forces[k].body)] = not w.forces[k].enabled
        return flags

    def _switch_due_bodies(self, Y: np.ndarray) -> np.ndarray:
        """Apply the ``Switch`` records due at this step, in the order they were added
        (``World.set_enabled``; each once, counted with the impulses). Y (N, W) is the state now;
        returned as the world holds it after."""
        w = self.world
        due = self._switches_due()
        if not due:
            return Y
        w.unpack(Y)
        for k in due:
            w.set_enabled(w.forces[k].body, w.forces[k].enabled)
            w.applied_impulses.add(k)
        return w.pack()

    def _take_type_changes(self, Y: np.ndarray) -> np.ndarray:
        """The bodies whose type was changed since this simulator last looked (``World.
        set_body_type``): the contact and joint stages made anew from the world as it is now (the
        shape table says which bodies move, the joint tree is cut at the fixed ones, the force
        tables list the moving ones), given their arrays of the step before as a restored snapshot
        is (``snapshot.restore_state``: the warm start and sleep timers kept); the blow-up check's
        energy taken again (a body let go brings its kinetic energy). A body made dynamic is
        woken by ``set_body_type``; the sleeping bodies it touches wake as any touched by an awake
        body do (a box asleep on a shelf made dynamic falls with it: tests/physics/
        test_body_type.py), so Box2D's wake of the contacts' bodies needs nothing more here.
        Y (N, W) is the state now; returned as the world holds it after."""
        from .collision.geometry import flatten_parts
        from .shapes import Mesh
        from .snapshot import restore_state, save_state

        w = self.world
        rows = w.type_changes[self._type_changes_seen:]
        self._type_changes_seen = len(w.type_changes)
        w.unpack(Y)
        gone = [i for i in set(rows) if w.disabled[i]]
        if gone and self.soft_step is not None:
            # the bodies that touched a body now disabled are woken (Box2D's b2Body_Disable wakes
            # the body's islands): a box asleep on a shelf that vanishes falls
            c = self.contacts()
            touched = np.isin(c.body_a, gone) | np.isin(c.body_b, gone)
            w.wake_requests.update(int(i) for i in np.concatenate([c.body_a[touched], c.body_b[touched]])
                                   if w.moving[i])
        if self.soft_step is not None:
            # The shape table holds which bodies move (read each step) and, for a triangle mesh,
            # its triangles on a fixed or kinematic body but its hull on a moving one: made anew
            # only for a mesh (the table is most of a new pipeline's cost: a type change in the
            # 1000-box pile took 20 ms, 11 more than a step, with the table made anew each time)
            mesh = any(isinstance(part, Mesh) for i in set(rows) for part, _, _ in flatten_parts(w.shapes[i]))
            restore_state(self, save_state(self), keep_table=not mesh)  # its wake requests are the world's now
            table = self.soft_step.pipeline.table
            if table is not None:
                table.body_moving[:] = w.moving
        self._reset_energy_reference()
        return w.pack()

    def _take_joint_edits(self):
        """The joint records edited since this simulator last looked (a field set after
        ``add_joint``, a target, torque or motor set between steps: ``tumble.joints.mark_edited``):
        their bodies woken at the next step (``world.wake_requests``: Box2D's joint setters wake
        the joint's bodies; a sleeping arm given a new drive target stayed where it was) and their
        rows in the joint solver's table (which the solver would take in its next ``prepare``;
        taken here so that a checkpoint saved now carries them)."""
        from .joints import edited_since

        w = self.world
        joints = getattr(w, "joints", [])
        for k in edited_since(joints, self._joint_edits_seen):
            b = joints[k].bound
            w.wake_requests.update(int(i) for i in (b.body_a, b.body_b) if i >= 0)
        self._joint_edits_seen = _joint_edit_count()
        solver = None if self.soft_step is None else self.soft_step.joints
        if solver is not None and solver.count == len(joints):
            solver.take_edits()

    def _take_force_edits(self):
        """The bodies of the force records edited since this simulator last looked (a field set on
        an added record: ``forces._ForceRecord``) woken at the next step: a resting box given a push,
        a hanging weight given a stiffer spring (a record over all bodies: all of them)."""
        w = self.world
        seen = self._force_edits_seen
        for f in w.forces:
            if f._edit_stamp <= seen:
                continue
            if getattr(f, "bodies", 0) is None:  # a drag or fluid over every moving body
                w.wake_requests.update(int(i) for i in np.flatnonzero(w.moving))
            else:
                w.wake_requests.update(w.force_bodies(f))
        self._force_edits_seen = force_edit_count()

    def _sleep_state(self):
        """The ``SleepState`` (``self.sleep``) when the world lets bodies sleep, else None."""
        if not getattr(self.world, "sleeping", True):
            if self.sleep is not None:
                self.sleep.wake_all()
            return None
        if self.sleep is None:
            self.sleep = SleepState(self.world.body_count)
        return self.sleep

    def joint_readings(self) -> dict:
        """The joints' readings after the last step (``JointSolver.readings``): ``position`` (J,)
        rad or m, ``rate`` (J,), ``force`` (J, 3) N and ``torque`` (J, 3) N m on body b (world),
        ``enabled`` (J,) bool. Zeros (and enabled) before the first step."""
        J = len(getattr(self.world, "joints", ()))
        solver = None if self.soft_step is None else self.soft_step.joints
        # ``enabled`` from the records: a joint switched off or on since the last step (``joint.broken
        # = ...``) reads as it is now, not as the solver will take it at the next step (the solver's
        # own breaks are written into the records as they happen)
        enabled = np.array([not j.broken for j in self.world.joints], dtype=bool)
        if solver is None or getattr(solver, "count", 0) != J:
            return {"position": np.zeros(J), "rate": np.zeros(J), "force": np.zeros((J, 3)), "torque": np.zeros((J, 3)),
                    "enabled": enabled}
        return {**solver.readings(), "enabled": enabled}

    def set_joint_torque(self, joint, torque: float):
        """Apply ``torque`` (N m along a hinge; a force in N along a slider) from the next step on,
        on body b and the opposite on body a, until changed (PyBullet's ``TORQUE_CONTROL``; the
        joint record's ``torque`` / ``force`` field; ``Robot.set_joint_torque`` for robots).
        ``joint``: its record, name or index in ``world.joints``. Before the first step too."""
        from .joints import P_EFFORT, joint_index, set_record_effort

        joints = self.world.joints
        record = joints[joint_index(self.world, joint, "joint")]
        value = set_record_effort(record, torque)
        solver = None if self.soft_step is None else self.soft_step.joints
        if solver is not None and solver.count == len(joints):
            solver.param[solver.index(record), P_EFFORT] = value

    def set_joint_target(self, joint, target, velocity=None):
        """Move a joint's drive target from the next step on (PyBullet's ``targetPosition``, MuJoCo's
        ``springref`` or a position actuator's ctrl): rad or m for a hinge, slider or distance joint;
        for a ball joint a rotation of body_b relative to body_a from their pose at creation, in
        body_a's axes (the world's when body_a is the world): a rotation vector (3,) rad or a unit
        quaternion (4,) w, x, y, z (``BallJoint.target``), and ``velocity`` (3,) rad/s its target
        velocity (``BallJoint.target_velocity``, body_a's axes; None: unchanged); a hinge's or
        slider's ``velocity`` one number, rad/s or m/s (``target_velocity``: the rate its damping
        pulls to, PyBullet's ``targetVelocity``). The drive's
        stiffness and damping are the joint's own. ``joint``: its record, name or index in
        ``world.joints``. Before the first step too."""
        from .joints import joint_index, set_record_target

        joints = self.world.joints
        record = joints[joint_index(self.world, joint, "joint")]
        solver = None if self.soft_step is None else self.soft_step.joints
        if solver is not None and solver.count == len(joints):
            solver.set_target(record, target, velocity)  # the solver's row and the record's
        else:
            set_record_target(record, target, velocity)  # read by the solver when it builds its tables

    def joint_frame(self) -> dict:
        """``joint_readings`` under the trajectory's per-frame keys (``trajectory.joint_frame_shapes``)."""
        r = self.joint_readings()
        return {"joint_position": r["position"], "joint_rate": r["rate"], "joint_force": r["force"],
                "joint_torque": r["torque"], "joint_enabled": np.asarray(r["enabled"], dtype=float)}

    def contact_events(self):
        """The contact begin and end events since the last call (``solver.contact_events.
        ContactEvents``; needs ``Simulator(..., contact_events=True)``)."""
        if self._event_log is None:
            raise InputError("contact events are off: make the Simulator with contact_events=True", "contact_events")
        return self._event_log.drain()

    @property
    def largest_penetration(self) -> float | None:
        """m, >= 0: the deepest penetration of any contact point at any step since the run began
        (``run`` and ``run_to_file`` start it afresh; a resumed run goes on from its checkpoint),
        or None when no contact point was found (a world without contacts). Measured every step
        from the contact detection's separations (``contacts().separation``, < 0: penetration)
        at the step's start, before its impulses: summary.json's ``largest_penetration_m``."""
        low = self.stats.get("lowest_separation")
        return None if low is None else max(0.0, -float(low))

    def contacts(self):
        """The contacts of the last step (``tumble.solver.soft_step.Contacts``: bodies, points,
        normals, separations, normal and friction impulses, mean forces); empty without contact.
        Bodies asleep keep the contacts they fell asleep on (found as they fell asleep, with their
        last step's impulses: ``SleepState.keep_resting``; Box2D keeps a sleeping body's
        contacts), after the detected ones."""
        if self.soft_step is None:
            return SoftStep(self.world).query()
        c = self.soft_step.query()
        if self.sleep is None or not getattr(self.world, "sleeping", True):
            return c
        resting = self.sleep.resting_contacts(self.world.moving)
        if not len(resting["body_a"]):
            return c
        names = np.asarray(self.world.names, dtype=str)
        fields = {name: np.concatenate([getattr(c, name), resting[name]]) for name in resting}
        return type(c)(names_a=names[fields["body_a"]], names_b=names[fields["body_b"]], **fields)

    def _impulse_steps(self):
        return [self._impulse_step(imp) for imp in self.world.impulses]

    def _impulse_step(self, impulse) -> int:
        # the first step that starts at or after impulse.time (tumble.reference does the same)
        return int(math.ceil(impulse.time / self.dt - 1e-9))

    def _apply_due_impulses(self, Y: np.ndarray):
        """P += J, L += (p - x) x J for impulses and explosions due at this step (in the order they
        were added); an explosion at the poses of Y, its bodies woken (``collision.explosion``)."""
        W = Y.shape[1]
        applied = self.world.applied_impulses
        for k, imp in enumerate(self.world.forces):
            if not isinstance(imp, (Impulse, Explosion)) or k in applied or self._impulse_step(imp) > self.step_index:
                continue
            if isinstance(imp, Explosion):
                self._explode(imp, Y)
                applied.add(k)
                continue
            i = self.world.index_of(imp.body)
            if self.world.moving[i]:
                J = np.asarray(imp.impulse)
                p = Y[i, :3] if imp.point is None else np.asarray(imp.point)
                Y[i, W - 6:W - 3] += J
                Y[i, W - 3:] += np.cross(p - Y[i, :3], J)
            applied.add(k)

    def _explode(self, explosion, Y: np.ndarray):
        """Apply ``explosion`` to the packed state Y (N, W) at its own poses (the World's arrays may
        still hold the start of the call)."""
        from .collision.explosion import apply_blast, blast

        w = self.world
        n, W = Y.shape
        x = Y[:, :3]
        if w.layout == "matrix":
            R = Y[:, 3:12].reshape(n, 3, 3)
        else:
            R = np.stack([quat_to_matrix(Y[i, 3:7]) for i in range(n)]) if n else np.zeros((0, 3, 3))
        result = blast(w, explosion, x, R)  # R row by row as the world derives it (quat_to_matrix_into)
        if len(result):
            apply_blast(result, x, Y[:, W - 6:W - 3], Y[:, W - 3:])  # views: P and L in Y itself
            w.wake_requests.update(int(i) for i in np.unique(result.body))

    def _kernel_args(self):
        w = self.world
        tb = w.tables
        return (
            w.mass, w.inv_mass, w.inertia_body_inv, w.principal_q, w.principal_moments, w.moving, w.gravity,
            tb.uforce_kind, tb.uforce_param, tb.uforce_start, tb.spring_body, tb.spring_anchor, tb.spring_param,
        )

    def _advance_compiled(self, Y, n, s: Scratch, parallel: bool = True):
        h = self.dt / self.substeps
        args = self._kernel_args()
        if len(args[-3]):  # springs couple bodies: all bodies advance stage by stage
            K.step_kernel(self.integrator_id, self.world.layout_id, h, n * self.substeps, Y, *args, s.Y1, s.K, s.Kacc, s.R, s.v, s.omega, s.F, s.T)
        else:  # independent bodies: each takes all its steps in cache, in parallel chunks when many
            # NOTE: each parallel task writes only its own rows, so the bits do not depend on the thread count.
            kernel = K.step_bodies_parallel_kernel if parallel and len(Y) >= K.PARALLEL_MIN_BODIES else K.step_bodies_kernel
            kernel(self.integrator_id, self.world.layout_id, h, n * self.substeps, Y, *args[:-3])

    def _advance_stagewise(self, Y, n, s: Scratch, check=None):
        """The same steps as ``integrators._one_step``, stage by stage, with user callables between the kernels.

        With ``check``, it is called after each stage: accumulate_forces (F, T),
        integrate_free_motion (intermediate and final states), project_orientation.
        """
        w = self.world
        layout = w.layout_id
        moving = w.moving
        h = self.dt / self.substeps
        t = self.step_index * self.dt
        name = self.integrator

        def forces(t_stage, Yst):
            if check is not None and Yst is not Y:
                check(f"integrate_free_motion ({name}, intermediate state)", t_stage, Y=Yst)
            w.evaluate_forces(t_stage, Yst, s)
            if check is not None:
                check("accumulate_forces", t_stage, F=s.F, T=s.T)

        def derivative(t_stage, Yst, out):
            forces(t_stage, Yst)
            K.derivative_kernel(layout, Yst, s.R, s.v, s.omega, moving, s.F, s.T, out)

        def split_step(t0, hh):
            forces(t0, Y)
            K.kick_kernel(layout, Y, moving, s.F, s.T, 0.5 * hh)
            K.drift_kernel(layout, Y, moving, w.inv_mass, w.inertia_body_inv, w.principal_q, w.principal_moments, True, hh)
            closing_kick(t0 + hh, 0.5 * hh)

        def closing_kick(t1, half):
            """P, L += half (F, tau) with the forces of the end momenta: fixed-point iteration,
            each body stopped by ``integrators._split_step``'s tests (its bits), for forces that
            may read the velocities (a callable's are not known; one that does not gives the
            explicit kick's bits at the first pass)."""
            start = Y[:, -6:].copy()
            forces(t1, Y)
            K.kick_kernel(layout, Y, moving, s.F, s.T, half)
            explicit = Y[:, -6:].copy()
            going = np.asarray(moving, dtype=bool).copy()
            last = np.full(len(Y), np.inf)
            for _ in range(K.KICK_ITERATIONS):
                if not going.any():
                    return
                forces(t1, Y)
                rows = np.flatnonzero(going)
                new = start[rows].copy()
                new[:, :3] += half * s.F[rows]
                new[:, 3:] += half * s.T[rows]
                change = _kick_change(Y[rows, -6:], new, start[rows])
                Y[rows, -6:] = new
                converged = change <= K.KICK_CONVERGED  # body_motion._kick_verdict's tests
                stalled = ~converged & (change >= last[rows])
                back = rows[stalled & (change > K.KICK_STALLED)]
                Y[back, -6:] = explicit[back]
                going[rows[converged | stalled]] = False
                last[rows] = change

        integ = self.integrator_id
        for _ in range(n * self.substeps):
            if integ == K.EXPLICIT_EULER:
                derivative(t, Y, s.K)
                K.axpy_kernel(Y, h, s.K, Y)
            elif integ == K.MIDPOINT:
                derivative(t, Y, s.K)
                K.axpy_kernel(Y, 0.5 * h, s.K, s.Y1)
                derivative(t + 0.5 * h, s.Y1, s.K)
                K.axpy_kernel(Y, h, s.K, Y)
            elif integ == K.RK4:
                derivative(t, Y, s.K)
                K.axpy_kernel(s.K, 0.0, s.K, s.Kacc)
                K.axpy_kernel(Y, 0.5 * h, s.K, s.Y1)
                for stage in range(3):
                    derivative(t + (0.5 * h if stage < 2 else h), s.Y1, s.K)
                    if stage < 2:
                        K.axpy_kernel(s.Kacc, 2.0, s.K, s.Kacc)
                        K.axpy_kernel(Y, 0.5 * h if stage == 0 else h, s.K, s.Y1)
                    else:
                        K.axpy_kernel(s.Kacc, 1.0, s.K, s.Kacc)
                K.axpy_kernel(Y, h / 6.0, s.Kacc, Y)
            elif integ == K.SEMI_IMPLICIT_EULER:
                forces(t, Y)
                K.kick_kernel(layout, Y, moving, s.F, s.T, h)
                K.drift_kernel(layout, Y, moving, w.inv_mass, w.inertia_body_inv, w.principal_q, w.principal_moments, False, h)
            elif integ == K.SPLITTING:
                split_step(t, h)
            elif integ == K.SPLITTING4:
                t0 = t
                for weight in (K._YOSHIDA_W1, K._YOSHIDA_W0, K._YOSHIDA_W1):
                    split_step(t0, weight * h)
                    t0 += weight * h
            if check is not None:
                check(f"integrate_free_motion ({name})", t, Y=Y)
            K.project_orientation_kernel(layout, Y, moving)
            t += h
            if check is not None:
                check("project_orientation", t, Y=Y)

    def _advance_adaptive(self, Y, n):
        """solve_ivp (RK45 or DOP853) on World.dxdt over n * dt, then project the orientation."""
        from scipy.integrate import solve_ivp

        w = self.world
        t0 = self.step_index * self.dt
        t1 = (self.step_index + n) * self.dt
        sol = solve_ivp(w.dxdt, (t0, t1), Y.ravel(), method=K.ADAPTIVE[self.integrator_id], rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise SimulationError(f"{self.integrator} failed between t = {t0:g} s and {t1:g} s: {sol.message}")
        self.stats["derivative_evaluations"] += int(sol.nfev)
        Y = np.ascontiguousarray(sol.y[:, -1].reshape(Y.shape))
        K.project_orientation_kernel(w.layout_id, Y, w.moving)
        return Y

    # ------------------------------------------------------------------ checks at stages
    def _stage_check(self, stage, t, Y=None, F=None, T=None):
        """Blow-up check after one stage (used by the diagnosis replay): raises SimulationError."""
        w = self.world
        where = f"step {int(math.floor(t / self.dt + 1e-9)) + 1}, {self.integrator}, dt = {self.dt:g} s"
        if Y is not None:
            unit = stage in ("project_orientation", "apply_impulses")
            problem = checks.state_problem(Y, w.layout, w.moving, check_unit=unit)
            if problem is not None:
                raise checks.blow_up(w.names, problem[0], problem[1], t, stage, where)
        for key, arr in (("F", F), ("T", T)):
            if arr is not None and not np.all(np.isfinite(arr)):
                i = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
                quantity = f"non-finite {checks.QUANTITY_NAMES[key]} = {checks._describe_row(arr[i])}"
                raise checks.blow_up(w.names, i, quantity, t, stage, where)

    def _validate_stage(self, stage, t, Y=None, F=None, T=None):
        """``TUMBLE_VALIDATE=1``: the stage check, and ``validate_world`` on the state after each step."""
        self._stage_check(stage, t, Y=Y, F=F, T=T)
        if stage == "project_orientation":
            w = self.world
            saved_t = w.t
            w.unpack(Y)
            w.t = t
            checks.validate_world(w, stage)
            w.t = saved_t

    def _diagnose(self, snapshot, steps: int, problem) -> SimulationError:
        """Replay the frame that went bad stage by stage from its start, to name the stage."""
        w = self.world
        Y0, step0, applied0, stats0 = snapshot
        self.step_index, w.applied_impulses, self.stats = step0, set(applied0), dict(stats0)
        w.t = step0 * self.dt
        # NOTE: the replay starts from the bodies' state only: the contact and joint solvers' warm starts
        # and the sleep state are those of the end, already non-finite when the solve blew up, so a
        # replay through the soft step named its first substep whatever the step (PyBullet's thrower,
        # 480 steps in one call: "t = 0.00104 s"); there, the span of steps is the honest report
        soft = self.soft_step
        replayable = soft is None or (soft.joints is None and soft.solver.count == 0 and soft.contacts is None)
        try:
            if self.integrator_id not in K.ADAPTIVE and replayable:
                with np.errstate(all="ignore"):
                    self._advance(Y0.copy(), steps, Scratch(w.body_count, w.state_size), check=self._stage_check)
        except SimulationError as err:
            return err
        # not reproduced stage by stage (or adaptive): report at the end of the frame
        t = (step0 + steps) * self.dt
        where = f"between steps {step0} and {step0 + steps}, {self.integrator}, dt = {self.dt:g} s"
        return checks.blow_up(w.names, problem[0], problem[1], t, "integrate_free_motion" if replayable else "soft_step",
                              where)

    # ------------------------------------------------------------------ the frame loop
    def _frame_plan(self, duration: float, frame_rate: float):
        """(frames, steps per frame) for ``duration`` s at ``frame_rate``, or InputError."""
        try:
            duration = float(duration)
            frame_rate = float(frame_rate)
        except (TypeError, ValueError):
            raise InputError("duration and frame_rate must be numbers", "simulation.duration") from None
        if not math.isfinite(duration) or duration <= 0:
            raise InputError(f"must be a positive finite number, got {duration}", "simulation.duration")
        if not math.isfinite(frame_rate) or frame_rate <= 0:
            raise InputError(f"must be a positive finite number, got {frame_rate}", "simulation.frame_rate")
        check_step_count(duration, frame_rate, self.dt, self.substeps)
        steps_per_frame = steps_between(1.0 / frame_rate, self.dt, "1 / frame_rate")
        frames = int(round(duration * frame_rate))
        if abs(frames - duration * frame_rate) > 1e-6 * max(1.0, frames):
            raise InputError(f"duration ({duration:g} s) must be a whole number of frames at {frame_rate:g} per second", "simulation.duration")
        return frames, steps_per_frame

    def run(self, duration: float, frame_rate: float = 24.0, progress: bool | None = None) -> Trajectory:
        """Run for ``duration`` s from the world's current time, recording frames at ``frame_rate`` per second.

        Frame 0 is the current state; then one frame every 1/frame_rate s
        (course Algorithm 5 with ERRATA 3: solve once per frame, then display).
        The frames are kept in memory: a run whose frames would not fit under
        ``checks.memory_limit()`` is refused (InputError) before it starts;
        ``run_to_file`` streams them to disk instead.

        Args:
            duration: s, > 0. frame_rate: frames per second (default 24, the course's).
            progress: show a progress bar (tqdm, shown only once a run has
                lasted a second); None shows it only on a terminal.

        Raises:
            SimulationError: a blow-up (non-finite state, orientation off unit
                length, energy past ``max_energy_growth``): one line naming the
                body, the time, the quantity and the stage. The world is left at
                the last good frame (the last recorded one for an energy blow-up).
        """
        frames, steps_per_frame = self._frame_plan(duration, frame_rate)
        n = self.world.body_count
        # the recorder's arrays, then the trajectory's copy of them
        checks.check_memory(2 * (frames + 1) * (n * checks.FRAME_BYTES_PER_BODY + 80), f"keeping {frames + 1} frames of {n} bodies in memory",
                            "simulation.duration")
        rec = _Recorder(self.world, frames + 1, self if self.record_contacts else None, self if self.record_joints else None,
                        self if self._sensing() else None, self)
        self.world.update_derived()
        self._sense_now()
        rec.record()
        self._reset_energy_reference()
        self.stats["lowest_separation"] = None  # largest_penetration: this run's
        started = _time.perf_counter()
        self._loop(frames, steps_per_frame, rec.record, progress)
        self.stats["wall_time_s"] = _time.perf_counter() - started
        return rec.trajectory()

    def _reset_energy_reference(self):
        w = self.world
        with np.errstate(over="ignore", invalid="ignore"):
            self.energy_reference = [w.kinetic_energy() + w.potential_energy(), checks.energy_scale(w), len(w.applied_impulses)]

    def _loop(self, frames: int, steps_per_frame: int, record, progress, after_frame=None):
        """Advance ``frames`` frames, calling ``record()`` after each, checking for blow-ups.

        ``after_frame()`` is called after each recorded frame and stops the loop
        when it returns True. On any exception the world is put back at the last
        recorded frame (except an energy blow-up, whose frame is recorded).
        """
        w = self.world
        w.update_derived()
        Y = w.pack()
        problem = checks.state_problem(Y, w.layout, w.moving)
        if problem is not None:
            raise checks.blow_up(w.names, problem[0], problem[1], w.t, "check_state", f"start of step {self.step_index + 1}")
        scratch = Scratch(w.body_count, w.state_size)
        bar = _progress_bar(frames, progress)
        notice = _first_frame_notice() if bar is not None else None
        try:
            for _ in range(frames):
                snapshot = (Y.copy(), self.step_index, set(w.applied_impulses), dict(self.stats))
                types = self._type_mark()
                try:
                    Y = self._advance_steps(Y, steps_per_frame, scratch)
                    problem = checks.state_problem(Y, w.layout, w.moving)
                    if problem is not None:
                        self._put_types_back(types)  # the replay starts from the frame's start
                        raise self._diagnose((snapshot[0].copy(),) + snapshot[1:], steps_per_frame, problem)
                except BaseException:
                    self._put_types_back(types)
                    self._restore(snapshot)
                    raise
                w.unpack(Y)
                record()
                self._check_energy()
                if notice is not None:
                    notice.cancel()
                    notice = None
                if bar is not None:
                    bar.update(1)
                if after_frame is not None and after_frame():
                    break
        finally:
            if notice is not None:
                notice.cancel()
            if bar is not None:
                bar.close()

    def _restore(self, snapshot):
        w = self.world
        Y0, self.step_index, applied, self.stats = snapshot
        w.applied_impulses = set(applied)
        w.t = self.step_index * self.dt
        if len(Y0) != w.body_count:  # bodies added since (a controller's: refused): they keep their state
            Y = w.pack()
            Y[:len(Y0)] = Y0
            Y0 = Y
        w.unpack(Y0)

    def _check_energy(self):
        w = self.world
        e_ref, scale, applied = self.energy_reference
        if len(w.applied_impulses) != applied:  # an impulse added energy: measure from here
            with np.errstate(over="ignore", invalid="ignore"):
                e_ref = w.kinetic_energy() + w.potential_energy()
            self.energy_reference = [e_ref, max(scale, checks.energy_scale(w)), len(w.applied_impulses)]
            e_ref, scale, _ = self.energy_reference
        checks.check_energy(w, e_ref, scale, self.max_energy_growth, f"end of step {self.step_index}, {self.integrator}, dt = {self.dt:g} s")

    # ------------------------------------------------------------------ streaming runs and checkpoints
    def run_to_file(self, out_dir, duration: float, frame_rate: float = 24.0, *, checkpoint_every: float | None = None,
                    progress: bool | None = None, handle_signals: bool = False, summary=None, resume: bool = False,
                    run_info: dict | None = None) -> "RunResult":
        """Run like ``run``, streaming frames to ``out_dir/trajectory.npz`` (peak memory independent of duration).

        Writes into ``out_dir``: ``trajectory.npz`` (all frames, rewritten
        atomically at every flush), ``checkpoint.npz`` (``save_checkpoint``) and
        ``summary.json`` (``summary(result)``, a dict; default
        ``RunResult.figures``), plus the work folder ``.trajectory.parts/`` of
        raw frame data, removed when the run completes. A flush (trajectory,
        then checkpoint, then summary) happens every ``checkpoint_every``
        simulated seconds (rounded to whole frames), and when the run ends,
        fails or is interrupted, so a killed process leaves every frame up to
        its last flush in a loadable file.

        Args:
            out_dir: output folder (created).
            duration: s of the whole run, counted from its start (for ``resume``,
                the start of the run that wrote ``out_dir``).
            frame_rate: frames per second.
            checkpoint_every: simulated seconds between flushes; None flushes only at the end.
            progress: progress bar (as ``run``).
            handle_signals: catch SIGINT and SIGTERM (main thread only): the run stops
                after the current frame with status "interrupted" (``result.signal``).
            summary: ``f(RunResult) -> dict`` written as summary.json at every flush.
            resume: continue the run in ``out_dir``: this simulator must come from
                ``Simulator.load_checkpoint(out_dir / "checkpoint.npz")``.
            run_info: extra JSON data kept in the checkpoint (e.g. the scene).

        Returns:
            ``RunResult`` (status "completed" or "interrupted").

        Raises:
            SimulationError: a blow-up; the frames so far, a checkpoint at the last good
                frame and a summary with status "failed" are written first.
            KeyboardInterrupt: (without ``handle_signals``) after writing the frames so
                far, a checkpoint and a summary with status "interrupted".
        """
        from .runfile import stream_run

        return stream_run(self, out_dir, duration, frame_rate, checkpoint_every=checkpoint_every, progress=progress,
                          handle_signals=handle_signals, summary=summary, resume=resume, run_info=run_info)

    def save_checkpoint(self, path, run: dict | None = None) -> Path:
        """Write the world (bodies, shapes, forces, state bits), the time, the settings and
        the impulses already applied to ``path`` (.npz, no pickles), atomically.

        ``Simulator.load_checkpoint(path)`` rebuilds an equal World and Simulator whose
        continuation is bit-identical. ``CustomForce`` functions are not data: they are
        recorded as placeholders and must be given back to ``load_checkpoint``.
        """
        from .checkpoint import save_checkpoint

        if isinstance(path, (str, Path)) and Path(path).is_dir():
            raise InputError("is a folder, not a checkpoint file (give a file name, e.g. run/checkpoint.npz)", None, str(path))
        self._take_joint_edits()  # the rows and the wakes of records edited since the last step
        self._take_force_edits()
        return save_checkpoint(self, path, run)

    def save_state(self):
        """The simulation's state now, in memory (``tumble.snapshot.SimState``: PyBullet's
        ``saveState``, MuJoCo's ``mj_getState``): the bodies' state, the time, the joints broken,
        the impulses applied, and the contact, sleep and joint solvers' arrays that the next
        step reads. ``restore_state`` puts it back; the steps after are bit-identical to those
        taken from the save. The world's description (bodies, shapes, forces, joints,
        materials) is not in it: it stays the world's."""
        from .snapshot import save_state

        self._take_joint_edits()
        self._take_force_edits()
        return save_state(self)

    def restore_state(self, state) -> None:
        """Put a ``save_state`` state back, in place (the world and its ``Body`` handles stay the
        same objects). The world must have the bodies and joints it had at the save, and the
        simulator the same dt. Undrained contact and sensor events are dropped, and
        ``contacts()`` is empty until the next step (the contact pipeline is made anew, as a
        loaded checkpoint's is).

        Raises:
            InputError: ``state`` is not a ``SimState``, or is of another world or dt (one line).
        """
        from .snapshot import restore_state

        restore_state(self, state)

    @classmethod
    def load_checkpoint(cls, path, custom_forces=None) -> "Simulator":
        """A Simulator on a new World rebuilt from a checkpoint file (loaded with ``allow_pickle=False``).

        Args:
            path: a file written by ``save_checkpoint``.
            custom_forces: the functions of the world's ``CustomForce`` records, in order.

        Returns:
            the Simulator (``.world`` is the rebuilt World; ``.checkpoint_run`` the
            ``run`` data saved with it, or None).

        Raises:
            InputError: a missing, damaged or inconsistent file (one line).
        """
        from .checkpoint import load_checkpoint

        return load_checkpoint(cls, path, custom_forces)

    def settings(self) -> dict:
        """The settings that make a continuation identical (JSON values)."""
        return {"dt": self.dt, "integrator": self.integrator, "substeps": self.substeps, "rtol": self.rtol, "atol": self.atol,
                "max_energy_growth": self.max_energy_growth,
                "contact": dataclasses.asdict(self.contact_settings or SoftStepSettings()),
                "record_contacts": self.record_contacts, "record_joints": self.record_joints,
                "contact_events": self._event_log is not None,
                "joint_solver": None if self.joint_settings is None else dataclasses.asdict(self.joint_settings)}


def _kick_change(old: np.ndarray, new: np.ndarray, start: np.ndarray) -> np.ndarray:
    """``body_motion._kick_change`` of each row: (B,) the larger change of P or L from ``old``
    to ``new`` (B, 6) relative to the larger of ``new``'s and ``start``'s (max norms; 0 where a
    change is 0)."""
    worst = np.zeros(len(new))
    for cols in (slice(0, 3), slice(3, 6)):
        d = np.abs(new[:, cols] - old[:, cols]).max(axis=1)
        scale = np.maximum(np.abs(new[:, cols]).max(axis=1), np.abs(start[:, cols]).max(axis=1))
        rel = np.divide(d, scale, out=np.zeros_like(d), where=d > 0.0)
        worst = np.maximum(worst, rel)
    return worst
