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

import json
import math
import time as _time

import numpy as np

from . import integrators as K
from .errors import InputError, SimulationError
from .shapes import shape_to_dict
from .trajectory import Trajectory
from .world import Scratch, World


def steps_between(interval: float, dt: float, what: str) -> int:
    """Whole number of steps of dt in ``interval`` (within 1e-6 of a step), or InputError."""
    n = interval / dt
    k = int(round(n))
    if k < 1 or abs(n - k) > 1e-6 * max(1.0, n):
        raise InputError(f"{what} ({interval:g} s) must be a whole number of steps dt = {dt:g} s", "simulation.dt")
    return k


class Simulator:
    """Steps a ``World`` in time and records frames.

    Args:
        world: the bodies and forces.
        dt: internal step, s (default 1/240). For ``rk45``/``dop853`` it is
            only the interval at which impulses can act; their own step is adaptive.
        integrator: one of ``integrators.INTEGRATOR_IDS`` (default "rk4":
            fourth order, 1e-6 rad after 10 s of a tumbling box at 1/240 s;
            see docs/integrators.md).
        substeps: each step is made of this many integrator steps of dt/substeps.
        rtol, atol: tolerances of the adaptive integrators (defaults 1e-10, 1e-12).
    """

    def __init__(self, world: World, dt: float = 1.0 / 240.0, integrator: str = "rk4", substeps: int = 1, rtol: float = 1e-10, atol: float = 1e-12):
        if integrator not in K.INTEGRATOR_IDS:
            names = ", ".join(K.INTEGRATOR_IDS)
            raise InputError(f"unknown integrator {integrator!r} (expected one of {names})", "simulation.integrator")
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            raise InputError(f"expected a number, got {dt!r}", "simulation.dt") from None
        if not math.isfinite(dt) or dt <= 0:
            raise InputError(f"must be a positive finite number, got {dt}", "simulation.dt")
        if int(substeps) != substeps or substeps < 1:
            raise InputError(f"must be a whole number >= 1, got {substeps!r}", "simulation.substeps")
        self.world = world
        self.dt = dt
        self.integrator = integrator
        self.integrator_id = K.INTEGRATOR_IDS[integrator]
        self.substeps = int(substeps)
        self.rtol = float(rtol)
        self.atol = float(atol)
        # steps of dt since t = 0: a Simulator on a world that has already run goes on from its time
        self.step_index = int(round(world.t / dt))
        self.stats = {"steps": 0, "derivative_evaluations": 0}

    # ------------------------------------------------------------------ stepping
    def step(self, count: int = 1):
        """Advance the world by ``count`` steps of dt (applying due impulses first)."""
        Y = self.world.pack()
        scratch = Scratch(self.world.body_count, self.world.state_size)
        Y = self._advance(Y, count, scratch)
        self.world.unpack(Y)

    def _advance(self, Y: np.ndarray, count: int, scratch: Scratch) -> np.ndarray:
        """Advance the packed state Y by ``count`` steps, splitting at impulse times."""
        end = self.step_index + count
        while self.step_index < end:
            self._apply_due_impulses(Y)
            nxt = min([end] + [k for k in self._impulse_steps() if k > self.step_index])
            n = nxt - self.step_index
            if self.integrator_id in K.ADAPTIVE:
                Y = self._advance_adaptive(Y, n)
            elif self.world.tables.custom:
                self._advance_stagewise(Y, n, scratch)
            else:
                self._advance_compiled(Y, n, scratch)
            self.step_index = nxt
            self.world.t = self.step_index * self.dt
            self.stats["steps"] += n * self.substeps
        return Y

    def _impulse_steps(self):
        return [self._impulse_step(imp) for imp in self.world.impulses]

    def _impulse_step(self, impulse) -> int:
        # the first step that starts at or after impulse.time (tumble.reference does the same)
        return int(math.ceil(impulse.time / self.dt - 1e-9))

    def _apply_due_impulses(self, Y: np.ndarray):
        """P += J, L += (p - x) x J for impulses due at this step (in the order they were added)."""
        W = Y.shape[1]
        applied = self.world.applied_impulses
        for imp in self.world.impulses:
            if id(imp) in applied or self._impulse_step(imp) > self.step_index:
                continue
            i = self.world.index_of(imp.body)
            if self.world.moving[i]:
                J = np.asarray(imp.impulse)
                p = Y[i, :3] if imp.point is None else np.asarray(imp.point)
                Y[i, W - 6:W - 3] += J
                Y[i, W - 3:] += np.cross(p - Y[i, :3], J)
            applied.add(id(imp))

    def _kernel_args(self):
        w = self.world
        tb = w.tables
        return (
            w.mass, w.inv_mass, w.inertia_body_inv, w.principal_q, w.principal_moments, w.moving, w.gravity,
            tb.uforce_kind, tb.uforce_param, tb.uforce_start, tb.spring_body, tb.spring_anchor, tb.spring_param,
        )

    def _advance_compiled(self, Y, n, s: Scratch):
        h = self.dt / self.substeps
        args = self._kernel_args()
        if len(args[-3]):  # springs couple bodies: all bodies advance stage by stage
            K.step_kernel(self.integrator_id, self.world.layout_id, h, n * self.substeps, Y, *args, s.Y1, s.K, s.Kacc, s.R, s.v, s.omega, s.F, s.T)
        else:  # independent bodies: each takes all its steps in cache, in parallel chunks when many
            kernel = K.step_bodies_parallel_kernel if len(Y) >= K.PARALLEL_MIN_BODIES else K.step_bodies_kernel
            kernel(self.integrator_id, self.world.layout_id, h, n * self.substeps, Y, *args[:-3])

    def _advance_stagewise(self, Y, n, s: Scratch):
        """The same steps as ``integrators._one_step``, stage by stage, with user callables between the kernels."""
        w = self.world
        layout = w.layout_id
        moving = w.moving
        h = self.dt / self.substeps
        t = self.step_index * self.dt

        def forces(t_stage, Yst):
            w.evaluate_forces(t_stage, Yst, s)

        def derivative(t_stage, Yst, out):
            forces(t_stage, Yst)
            K.derivative_kernel(layout, Yst, s.R, s.v, s.omega, moving, s.F, s.T, out)

        def split_step(t0, hh):
            forces(t0, Y)
            K.kick_kernel(layout, Y, moving, s.F, s.T, 0.5 * hh)
            K.drift_kernel(layout, Y, moving, w.inv_mass, w.inertia_body_inv, w.principal_q, w.principal_moments, True, hh)
            forces(t0 + hh, Y)
            K.kick_kernel(layout, Y, moving, s.F, s.T, 0.5 * hh)

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
            K.project_orientation_kernel(layout, Y, moving)
            t += h

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

    # ------------------------------------------------------------------ the frame loop
    def run(self, duration: float, frame_rate: float = 24.0, progress: bool | None = None) -> Trajectory:
        """Run for ``duration`` s from the world's current time, recording frames at ``frame_rate`` per second.

        Frame 0 is the current state; then one frame every 1/frame_rate s
        (course Algorithm 5 with ERRATA 3: solve once per frame, then display).

        Args:
            duration: s, > 0. frame_rate: frames per second (default 24, the course's).
            progress: show a progress bar (tqdm, shown only once a run has
                lasted a second); None shows it only on a terminal.
        """
        try:
            duration = float(duration)
            frame_rate = float(frame_rate)
        except (TypeError, ValueError):
            raise InputError("duration and frame_rate must be numbers", "simulation.duration") from None
        if not math.isfinite(duration) or duration <= 0:
            raise InputError(f"must be a positive finite number, got {duration}", "simulation.duration")
        if not math.isfinite(frame_rate) or frame_rate <= 0:
            raise InputError(f"must be a positive finite number, got {frame_rate}", "simulation.frame_rate")
        steps_per_frame = steps_between(1.0 / frame_rate, self.dt, "1 / frame_rate")
        frames = int(round(duration * frame_rate))
        if abs(frames - duration * frame_rate) > 1e-6 * max(1.0, frames):
            raise InputError(f"duration ({duration:g} s) must be a whole number of frames at {frame_rate:g} per second", "simulation.duration")

        w = self.world
        w.update_derived()
        rec = _Recorder(w, frames + 1)
        rec.record()
        Y = w.pack()
        scratch = Scratch(w.body_count, w.state_size)
        bar = _progress_bar(frames, progress)
        started = _time.perf_counter()
        try:
            for _ in range(frames):
                Y = self._advance(Y, steps_per_frame, scratch)
                w.unpack(Y)
                self._check_finite(Y)
                rec.record()
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        self.stats["wall_time_s"] = _time.perf_counter() - started
        return rec.trajectory()

    def _check_finite(self, Y):
        bad = ~np.all(np.isfinite(Y), axis=1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise SimulationError(f"body {self.world.names[i]!r}: non-finite state at t = {self.world.t:g} s (integrator {self.integrator}, dt = {self.dt:g} s)")


def _progress_bar(frames: int, progress: bool | None):
    import sys

    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    from tqdm import tqdm

    return tqdm(total=frames, unit="frame", delay=1.0, file=sys.stderr, leave=False)


class _Recorder:
    """Pre-allocated frame arrays, filled from the World one frame at a time."""

    def __init__(self, world: World, capacity: int):
        self.world = world
        n = world.body_count
        self.count = 0
        self.time = np.zeros(capacity)
        self.position = np.zeros((capacity, n, 3))
        self.orientation = np.zeros((capacity, n, 4))
        self.velocity = np.zeros((capacity, n, 3))
        self.angular_velocity = np.zeros((capacity, n, 3))
        self.linear_momentum = np.zeros((capacity, n, 3))
        self.angular_momentum = np.zeros((capacity, n, 3))
        self.kinetic_energy = np.zeros(capacity)
        self.potential_energy = np.zeros(capacity)
        self.total_linear_momentum = np.zeros((capacity, 3))
        self.total_angular_momentum = np.zeros((capacity, 3))
        self.orthonormality_error = np.zeros(capacity)

    def record(self):
        # A run heading for a blow-up may overflow the diagnostics before the state
        # itself turns non-finite: record inf, and let _check_finite report the body.
        with np.errstate(over="ignore", invalid="ignore"):
            self._record()

    def _record(self):
        w, k = self.world, self.count
        self.time[k] = w.t
        self.position[k] = w.x
        self.orientation[k] = w.q
        self.velocity[k] = w.v
        self.angular_velocity[k] = w.omega
        self.linear_momentum[k] = w.P
        self.angular_momentum[k] = w.L
        self.kinetic_energy[k] = w.kinetic_energy()
        self.potential_energy[k] = w.potential_energy()
        self.total_linear_momentum[k] = w.linear_momentum()
        self.total_angular_momentum[k] = w.angular_momentum()
        self.orthonormality_error[k] = w.orthonormality_error()
        self.count += 1

    def trajectory(self) -> Trajectory:
        k = self.count
        return Trajectory(
            time=self.time[:k].copy(),
            names=np.array(self.world.names, dtype=str),
            position=self.position[:k].copy(),
            orientation=self.orientation[:k].copy(),
            velocity=self.velocity[:k].copy(),
            angular_velocity=self.angular_velocity[:k].copy(),
            linear_momentum=self.linear_momentum[:k].copy(),
            angular_momentum=self.angular_momentum[:k].copy(),
            kinetic_energy=self.kinetic_energy[:k].copy(),
            potential_energy=self.potential_energy[:k].copy(),
            total_linear_momentum=self.total_linear_momentum[:k].copy(),
            total_angular_momentum=self.total_angular_momentum[:k].copy(),
            orthonormality_error=self.orthonormality_error[:k].copy(),
            com_offset=self.world.com_offset.copy(),
            shapes=np.array([json.dumps(shape_to_dict(sh)) for sh in self.world.shapes], dtype=str),
            fixed=self.world.fixed.copy(),
        )
