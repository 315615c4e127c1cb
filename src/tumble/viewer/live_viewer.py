"""The live viewer: a scene simulated in the browser as it is watched, and poked.

``tumble view SCENE --live`` (or ``tumble.viewer.live(scene)``) runs the scene's
``Simulator`` in a background thread at real time (times a speed factor) and sends
the bodies' poses to the browser after each batch of steps, as MuJoCo's
``python -m mujoco.viewer`` and PyBullet's GUI do. The scene is the one
``tumble run`` would run: the same dt, integrator, contacts, joints, robots and
controllers; the viewer only calls ``Simulator.step`` between its frames, so that
what it shows after n steps has the bits of a plain run of n steps (tested).

What it adds to the playback viewer (``tumble.viewer.app``, whose meshes, picking,
body quantities and toggles it shares):

* "Live": Play / Pause, "Step" (one frame: 1/24 s, or the scene's frame rate),
  "Reset" (the scene made again from its file: bit-identical to the first start), "Save"
  (the run so far, recorded at the frame rate as ``Simulator.run`` records it, written to
  ``out/run-NNN/trajectory.npz`` and ``trajectory.glb``), "Mark" and "Back to mark" (a snapshot of
  the run, ``Simulator.save_state``, and the run returned to it, its recording cut back: try a
  push again from the same moment),
  a speed factor, and the time with the real-time factor reached (a scene whose
  steps cost more than real time runs slower, never in bigger steps);
* "Click a body to": select it (its x, v, omega, P, L, energy); push it (an
  impulse ``m * push speed`` along the click's ray, at the point the ray hits,
  Box2D's ``b2Body_ApplyLinearImpulse``: the body's momentum changes by exactly
  that, its angular momentum by ``(p - x) x J``); or grab it: a spring from the
  point clicked to a handle (viser's transform controls) that the mouse drags,
  as MuJoCo's viewer perturbs a body (a mass-scaled spring of ``GRAB_HERTZ`` with
  a critical damping of the body's motion; "Release" or a click elsewhere lets
  go); or blast it: an explosion where the click's ray meets the scene (``World.explode``,
  Box2D's ``b2World_Explode``: full within the "Blast radius", fading over as far again,
  "Blast strength" N s per m^2 of each shape's shadow); pin it (made fixed where it is, or let
  go again); or remove it (``World.set_enabled(body, False)``: hidden and touching nothing until
  "Back to mark" or Reset puts it back). Shift + click pushes whatever the mode.
* the contact points and forces of the last step, from ``Simulator.contacts()``;
* the world as it is: a body out of the simulation (``World.set_enabled``, ``World.disabled``)
  is hidden while it is, and shown again when it is put back (a body added disabled is drawn
  as the type it comes back as: a dynamic one is moved once it appears);
* "Integration" (a scene file): the integrator and dt the next Reset starts with (the
  course's explicit Euler beside RK4 or the splitting, a step 4x larger or 10x smaller), and a
  plot of the kinetic, potential and total energy of the recorded frames (the drift an
  integrator leaves shows at once);
* "Cameras": the image of one of the scene's cameras (its ``[[cameras]]``, its MJCF models'
  ``<camera>``s: ``tb.Camera.capture``, the exact ray-cast image), colour or depth, renewed five
  times a second while running and after every step;
* "Controls": a slider per actuator of the scene's MJCF models (over its ``ctrlrange``,
  -1 .. 1 when unlimited, as MuJoCo's viewer), ``Robot.set_controls`` when moved; a slider per
  driven joint of a URDF robot (its motor's speed or its PD drive's target).

A step that blows up (``SimulationError``) pauses the run at the last good state and
shows the error's line in the status.
"""

from __future__ import annotations

import math
import time as _time
from pathlib import Path

import numpy as np

from ..errors import InputError, SimulationError
from ..forces import Drag, Spring
from ..shapes import Plane
from .. import checks
from ..recording import _Recorder, frame_values
from ..trajectory import Trajectory
from .app import SCENE_SUFFIXES, Viewer, check_address, open_in_browser

LIVE_TICK_S = 1.0 / 60.0  # s of wall time between pose updates when the steps keep up
TICK_BUDGET_S = 0.05  # s of wall time a tick may step before it sends poses (a slow scene still shows motion)
MAX_LAG_S = 0.1  # s of simulated time the run may owe real time; more is dropped (the run slows down)
PUSH_SPEED = 2.0  # m/s: a push's default change of speed (impulse = mass * speed)
GRAB_HERTZ = 2.0  # Hz: natural frequency of a grabbed body on the grab spring (stiffness = m (2 pi f)^2)
GRAB_DAMPING_RATIO = 1.0  # critical: the body follows the handle without swinging past it
CLICK_MODES = ("select", "push", "grab", "blast", "pin", "remove")
BLAST_RADIUS = 0.5  # m: a click's explosion, full strength within it (and as far again, fading)
BLAST_IMPULSE = 200.0  # N s / m^2: its impulse per area of a shape's shadow (a 20 cm cube face-on: 8 N s)
CAMERA_PERIOD_S = 0.2  # s of wall time between a camera's images while running (a capture costs 2-40 ms)
ENERGY_PLOT_FRAMES = 1200  # frames the energy plot shows (the last ones): 50 s at 24 fps
ENERGY_PLOT_PERIOD_S = 0.25  # s of wall time between the energy plot's updates while running
DT_FACTORS = (4.0, 2.0, 1.0, 0.5, 0.25, 0.1)  # the dt choices, times the scene's


def live(scene, host: str = "127.0.0.1", port: int = 8080, open_browser: bool = False, *, play: bool = True,
         frame_rate: float | None = None, out=None) -> "LiveViewer":
    """Start the live viewer on ``scene`` and return it at once (the server and the run are
    background threads; ``.stop()`` ends them).

    Args:
        scene: a scene file (``.toml``, ``.json``, or a MuJoCo ``.xml``), or a function of no
            arguments returning a new ``Simulator`` (or ``Scene``) each time it is called: the
            start and every Reset call it (a world built in Python: ``live(make_sim)``).
        host, port: where to serve (127.0.0.1: this machine only; port 0: any free port).
        open_browser: open the page in the system's browser.
        play: start running at once (False: paused at the start).
        frame_rate: frames per second of the Step button and of the recording (default: the
            scene's, else 24).
        out: folder where "Save" writes the runs (``run-001/``, ...; default ``tumble-live``).
    """
    if isinstance(scene, (str, Path)):
        path = Path(scene)
        if path.suffix.lower() not in SCENE_SUFFIXES:
            raise InputError(f"unknown file type {path.suffix!r} (the live viewer runs a scene .toml/.json or "
                             "a MuJoCo .xml; a trajectory .npz is played by tumble view without --live)", None, str(path))
        if not path.is_file():
            raise InputError("file not found" if not path.exists() else "not a file", None, str(path))

        def make():
            from ..scene import load_scene

            return load_scene(path)

        label = path.name
    elif callable(scene):
        make, label = scene, getattr(scene, "__name__", "the scene")
    else:
        raise InputError(f"expected a scene file or a function returning a Simulator, got {type(scene).__name__}", "scene")
    viewer = LiveViewer(make, host=host, port=port, play=play, frame_rate=frame_rate, label=label, out=out)
    if open_browser:
        open_in_browser(viewer.url)
    return viewer


def _simulator_of(made):
    """The ``Simulator`` of what a scene function returned (a ``Scene`` gives its own), with its
    frame rate (the scene's, or None) and its robots ({name: Robot})."""
    from ..scene import Scene
    from ..simulator import Simulator

    if isinstance(made, Scene):
        return made.simulator(), made.frame_rate, dict(made.robots), dict(made.cameras)
    if isinstance(made, Simulator):
        return made, None, {}, {}
    raise InputError(f"the scene function must return a Simulator or a Scene, got {type(made).__name__}", "scene")


class LiveViewer(Viewer):
    """A running live viewer: use ``live()`` to make one; ``stop()`` ends it.

    Attributes (besides ``Viewer``'s):
        sim: the ``Simulator`` being run (a new one after each ``reset()``).
        steps_per_frame: steps of the Step button (one frame at ``frame_rate``).
        real_time_factor: simulated seconds per wall second over the last second of running.
        error: the line of the ``SimulationError`` (or a user force's ``InputError``) that paused
            the run, or None.
        grabbed: (body index, its grab ``Spring``, its ``Drag``) while a body is grabbed, else None.
        robots: {name: Robot} of the scene's ``[[robots]]`` ({} for a scene function's Simulator).
        out: the folder ``save()`` writes into; saved: the folders written.
        step_button, reset_button, save_button, mark_button, back_button, click_dropdown, push_speed_slider,
        blast_radius_slider, blast_strength_slider, blast_shaded_checkbox, release_button,
        control_sliders ({(robot, actuator): slider}), grab_handle: the GUI handles added
        (``grab_handle``: the transform controls, or None).
    """

    def __init__(self, make_simulator, host: str = "127.0.0.1", port: int = 8080, *, play: bool = True,
                 frame_rate: float | None = None, label: str = "the scene", out=None):
        check_address(host, port)
        self._make_simulator = make_simulator
        self.label = label
        made = make_simulator()
        self._scene_dt = self._scene_integrator = None  # the file's (a Scene); None for a Simulator
        from ..scene import Scene

        if isinstance(made, Scene):
            self._scene_dt, self._scene_integrator = made.dt, made.integrator
        self.sim, scene_rate, self.robots, self.cameras = _simulator_of(made)
        self.frame_rate = float(frame_rate or scene_rate or 24.0)
        if not (math.isfinite(self.frame_rate) and self.frame_rate > 0):
            raise InputError(f"must be a positive number, got {frame_rate!r}", "frame_rate")
        self.steps_per_frame = self._steps_per_frame()
        # A first step loads (or compiles) the scene's kernels: seconds for a robot or contacts.
        # Taken here on a twin of the scene, so that the page opens on a run that already moves.
        _simulator_of(make_simulator())[0].step(1)
        self.out = Path("tumble-live" if out is None else out)
        self.saved: list[Path] = []
        self.error: str | None = None
        self._start_recording()
        self.grabbed: tuple[int, Spring, Drag] | None = None
        self.grab_handle = None
        self._mark = None  # (SimState, frames recorded) of "Mark", or None
        self.real_time_factor = 0.0
        self._lag = 0.0  # s of simulated time owed to real time
        self._rate_window: list[tuple[float, float]] = []  # (wall time, simulated time) over the last second
        self._force_max = 0.0
        self._plotted_at = 0.0  # wall time of the energy plot's last update
        self._captured_at = 0.0  # wall time of the camera image's last update
        # the recording's first frame (one copy of it) is the one-frame trajectory the viewer draws from
        super().__init__(self._recorder.trajectory(), host=host, port=port, play=False)
        assert self.position is self.traj.position and self.orientation is self.traj.orientation \
            and self.time is self.traj.time  # see _refresh
        self._refresh()
        self._plot_energy()
        if play:
            self.play()

    # ---- public API -------------------------------------------------------------------------

    @property
    def world(self):
        return self.sim.world

    def play(self):
        with self._lock:
            if self.error is not None:
                return  # a blown-up run stays paused until Reset
            self._playing = True
            self._lag = 0.0
        self.play_button.visible = False
        self.pause_button.visible = True

    def set_frame(self, k: int):
        raise InputError("a live run has no frames to go to: use step_frame() or reset()", "frame")

    def step_frame(self, frames: int = 1):
        """Advance ``frames`` frames (``steps_per_frame`` steps each) and show the result."""
        self.advance(frames * self.steps_per_frame)

    def advance(self, steps: int):
        """Advance the run ``steps`` steps of dt (``Simulator.step``) and show the result. A
        ``SimulationError`` pauses the run (the world back at the start of the call) and is kept
        in ``error``."""
        with self._lock:
            if self.error is not None or steps <= 0:
                return
            self._step(int(steps))
            self._refresh()
            self._plot_energy()
            self._show_camera()

    def reset(self):
        """Start again: a new ``Simulator`` from the scene (its file read again), paused."""
        with self._lock:
            self.pause()
            self._release_spring()
            scene = self._make_simulator()
            if self._scene_dt is not None:
                scene.integrator = self.integrator_dropdown.value
                scene.dt = self._dt_choices[self.dt_dropdown.value]
                scene.check()  # the choices were checked when offered: a changed file says so here
            made, _, robots, self.cameras = _simulator_of(scene)
            if made.world.names != self.sim.world.names or robots.keys() != self.robots.keys():
                raise InputError("the scene's bodies changed since the viewer started: start the viewer again", "scene")
            self.sim, self.robots = made, robots
            self._mark = None  # a mark of the run before the Reset (its frames are gone)
            self.back_button.disabled = True
            self.steps_per_frame = self._steps_per_frame()
            self.step_button.hint = f"one frame: {self.steps_per_frame} steps of {self.sim.dt:g} s"
            self._start_recording()
            self._show_controls()  # the scene's own controls again
            self.error = None
            self._rate_window.clear()
            self.real_time_factor = 0.0
            self._force_max = 0.0
            self._refresh()
            self._plot_energy()
            self._show_camera()

    def mark(self):
        """Remember this moment of the run (``Simulator.save_state``: the bodies, the solvers' warm
        starts, sleep, joints, contact and sensor pairs) and the frames recorded so far; "Back to
        mark" returns to it. A Reset forgets it."""
        with self._lock:
            self._mark = (self.sim.save_state(), self._recorder.count)
            self.back_button.disabled = False
            self.time_text.content = self._status_text(0)

    def back_to_mark(self):
        """Return the run to the last ``mark``: the state restored in place
        (``Simulator.restore_state``: the steps after it repeat a plain run's bits from there) and
        the recording cut back to the frames it had then, so a saved take holds one history. A
        grab is let go; the sliders' controls stay as they are. Paused."""
        with self._lock:
            if self._mark is None:
                raise InputError("no mark: press Mark first", "mark")
            self.pause()
            self._release_spring()
            state, frames = self._mark
            self.sim.restore_state(state)
            self._recorder.truncate(frames)
            self.error = None
            self._force_max = 0.0
            self._refresh()
            self._plot_energy()
            self._show_camera()

    def _steps_per_frame(self) -> int:
        return max(1, int(round(1.0 / (self.frame_rate * self.sim.dt))))

    def push(self, body, point=None, direction=(0.0, 0.0, 1.0), speed: float | None = None):
        """Push a dynamic body: an impulse ``J = m speed d / |d|`` (N s, world) at ``point`` ((3,) m,
        world; default its centre of mass), so that its centre of mass gains ``speed`` m/s along
        ``direction`` and L gains ``(point - x) x J`` (``Body.apply_impulse``; it wakes).
        ``speed`` defaults to the "Push speed" slider."""
        with self._lock:
            b = self.sim.world.body(body)
            if not self.sim.world.moving[b.index]:
                raise InputError(f"body {b.name!r} is not dynamic: only a dynamic body can be pushed", "push")
            speed = float(self.push_speed_slider.value if speed is None else speed)
            d = np.asarray(direction, dtype=float)
            norm = float(np.linalg.norm(d))
            if not (math.isfinite(norm) and norm > 0 and math.isfinite(speed)):
                raise InputError(f"needs a nonzero finite direction and speed, got {direction!r}, {speed!r}", "push")
            b.apply_impulse(float(self.sim.world.mass[b.index]) * speed * d / norm, point)
            self._refresh()

    def blast(self, position, radius: float | None = None, impulse_per_area: float | None = None,
              shaded: bool | None = None):
        """An explosion now at ``position`` ((3,) m, world): ``World.explode`` with ``radius`` (m, full
        strength) and as much again of falloff, ``impulse_per_area`` N s/m^2, ``shaded`` (bodies
        hidden from the centre spared; defaults: the "Blast" sliders and checkbox). Returns its
        ``Blast`` (the bodies hit and their impulses); they wake."""
        with self._lock:
            radius = float(self.blast_radius_slider.value if radius is None else radius)
            strength = float(self.blast_strength_slider.value if impulse_per_area is None else impulse_per_area)
            shaded = bool(self.blast_shaded_checkbox.value if shaded is None else shaded)
            result = self.sim.world.explode(position, radius=radius, impulse_per_area=strength, falloff=radius,
                                            shaded=shaded)
            self._refresh()
            return result

    def grab(self, body, point=None):
        """Hold a dynamic body by ``point`` ((3,) m, world, on the body; default its centre of mass):
        a spring of rest length 0 from that body point to a handle at ``point``, stiffness
        ``m (2 pi GRAB_HERTZ)^2``, with a drag ``2 GRAB_DAMPING_RATIO m omega`` on the body's
        velocity (and its angular counterpart), so that it follows ``move_grab`` without
        swinging; gravity still acts (held by its centre of mass, a body hangs ``g / omega^2``
        below the handle). One body at a time: a second grab lets the first go."""
        with self._lock:
            w = self.sim.world
            b = w.body(body)
            if not w.moving[b.index]:
                raise InputError(f"body {b.name!r} is not dynamic: only a dynamic body can be grabbed", "grab")
            self._release_spring()
            p = np.array(b.x if point is None else point, dtype=float)
            m = float(w.mass[b.index])
            omega = 2.0 * math.pi * GRAB_HERTZ
            anchor = w.R[b.index].T @ (p - w.x[b.index])  # body frame, centre-of-mass origin
            spring = w.add_force(Spring(body_a=b.index, anchor_a=anchor, body_b=None, anchor_b=p,
                                        stiffness=m * omega ** 2, damping=0.0, rest_length=0.0))
            c = 2.0 * GRAB_DAMPING_RATIO * m * omega
            # the angular drag: critical for a body whose inertia is its mean principal moment
            inertia = float(np.mean(w.principal_moments[b.index]))
            drag = w.add_force(Drag(linear=c, angular_linear=2.0 * GRAB_DAMPING_RATIO * omega * inertia, bodies=[b.index]))
            w.wake_requests.add(b.index)
            self._show_grab_handle(p)
            self.grabbed = (b.index, spring, drag)  # last: whoever sees it set sees the handle too

    def move_grab(self, target):
        """Move the grab handle to ``target`` ((3,) m, world)."""
        with self._lock:
            if self.grabbed is None:
                return
            index, spring, _ = self.grabbed
            target = np.asarray(target, dtype=float)
            if target.shape != (3,) or not np.all(np.isfinite(target)):
                raise InputError(f"expected a finite (3,) point, got {target!r}", "target")
            spring.anchor_b = tuple(float(c) for c in target)  # an added record's edit: acts at the next step
            self.sim.world.wake_requests.add(index)

    def release(self):
        """Let go of the grabbed body (if any)."""
        with self._lock:
            self._release_spring()

    def pin(self, body) -> bool:
        """Pin a dynamic body where it is, or unpin a pinned one: made fixed (``World.set_body_type``:
        it stops, and what hits it meets a fixed body) or dynamic again, from rest, with its mass.
        Only a body that was dynamic when the scene started (it is drawn as one that moves); a
        Reset unpins every body, and "Back to mark" puts back the pins of its moment. Returns
        whether the body is pinned now."""
        with self._lock:
            w = self.sim.world
            b = w.body(body)
            if not self._dynamic_at_start[b.index]:
                raise InputError(f"body {b.name!r} was not dynamic when the scene started: only such a body can be "
                                 "pinned", "pin")
            if b.index == (self.grabbed or (None,))[0]:
                self._release_spring()  # a pinned body cannot be held
            w.set_body_type(b.index, "fixed" if w.moving[b.index] else "dynamic")
            self._refresh()
            return bool(w.fixed[b.index])

    def remove(self, body):
        """Take a body out of the simulation (``World.set_enabled(body, False)``: hidden, touching
        nothing, its joints off): a wall cleared, a box pulled out of a tower. A plane stays (one
        InputError). Reset puts every body back, and "Back to mark" those of its moment."""
        with self._lock:
            w = self.sim.world
            b = w.body(body)
            if b.index == (self.grabbed or (None,))[0]:
                self._release_spring()  # nothing to hold
            w.set_enabled(b.index, False)
            self._refresh()

    # ---- the run ----------------------------------------------------------------------------

    def trajectory(self) -> Trajectory:
        """The run so far as ``tumble run`` records it: a frame at the start (or the last Reset) and
        one every ``steps_per_frame`` steps, pushes and grabs included (contacts and joints too when
        the scene records them). A run longer than the memory limit allows keeps its first frames."""
        with self._lock:
            return self._recorder.trajectory()

    def save(self) -> Path:
        """Write the run so far to a new folder ``out/run-NNN/``: ``trajectory.npz`` (for
        ``tumble view``, ``render``, ``export``) and ``trajectory.glb`` (Blender, three.js). Returns
        the folder."""
        from ..export import export_gltf

        traj = self.trajectory()
        self.out.mkdir(parents=True, exist_ok=True)
        k = 1
        while True:  # a new folder each time: nothing written before is touched
            folder = self.out / f"run-{k:03d}"
            try:
                folder.mkdir()
                break
            except FileExistsError:
                k += 1
        traj.save(folder / "trajectory.npz")
        export_gltf(traj, folder / "trajectory.glb")
        self.saved.append(folder)
        with self._lock:
            self.time_text.content = self._status_text(0)
        return folder

    def _start_recording(self):
        sim = self.sim
        # the bodies that may be pinned and unpinned (``pin``): drawn as moving ones from the start
        # (a body disabled at the start: the type it comes back as, World.body_type)
        self._dynamic_at_start = sim.world.body_types() == "dynamic"
        self._recorder = _Recorder(sim.world, 64, sim if sim.record_contacts else None, sim if sim.record_joints else None,
                                   sim if sim._sensing() else None, sim)
        n = sim.world.body_count
        self._max_frames = max(2, int((checks.memory_limit() or 2**62) // (2 * (n * checks.FRAME_BYTES_PER_BODY + 80))))
        # as Simulator.run starts: derived quantities and sensors brought up to date, then frame 0
        sim.world.update_derived()
        sim._sense_now()
        self._recorder.record()

    def _step(self, steps: int):
        """``steps`` steps, in pieces that end on frame boundaries, where a frame is recorded."""
        spf = self.steps_per_frame
        try:
            while steps > 0:
                if self.grabbed is not None:  # a held body may have fallen asleep in the handle's hand
                    self.sim.world.wake_requests.add(self.grabbed[0])
                take = min(steps, spf - self.sim.step_index % spf)
                self.sim.step(take)
                steps -= take
                if self.sim.step_index % spf == 0 and self._recorder.count < self._max_frames:
                    self._recorder.record()
        except (SimulationError, InputError) as err:  # a blow-up, or a user's force gone wrong
            self.error = str(err)
            self.pause()

    def _playback_loop(self):
        last = _time.monotonic()
        while not self._stop_event.wait(LIVE_TICK_S):
            now = _time.monotonic()
            elapsed, last = now - last, now
            if not self._playing:
                continue
            try:
                with self._lock:
                    if not self._playing:
                        continue
                    dt = self.sim.dt
                    self._lag = min(self._lag + elapsed * float(self.speed_slider.value), MAX_LAG_S)
                    started = _time.monotonic()
                    # step by step until the run has caught up or the tick's budget is spent: a
                    # slow scene keeps showing its motion, more slowly than real time
                    while self._lag >= dt and self._playing and _time.monotonic() - started < TICK_BUDGET_S:
                        self._step(1)
                        self._lag -= dt
                    if self._stop_event.is_set():  # stopped while stepping: the server is gone
                        return
                    self._refresh()
                    self._measure_rate(now)
                    if now - self._plotted_at >= ENERGY_PLOT_PERIOD_S:
                        self._plot_energy()
                        self._plotted_at = now
                    if now - self._captured_at >= CAMERA_PERIOD_S:
                        self._show_camera()
                        self._captured_at = _time.monotonic()
            except Exception:  # the server was stopped under us
                if self._stop_event.is_set():
                    return
                raise

    def _measure_rate(self, now: float):
        window = self._rate_window
        window.append((now, float(self.sim.world.t)))
        while len(window) > 2 and now - window[0][0] > 1.0:
            window.pop(0)
        wall = window[-1][0] - window[0][0]
        self.real_time_factor = (window[-1][1] - window[0][1]) / wall if wall > 0 else 0.0

    def _refresh(self):
        """Copy the world's state into the one-frame arrays and send the poses."""
        # the viewer's time, position and orientation are the trajectory's own float64 arrays
        # (``Viewer.__init__`` takes them by np.asarray): one write serves both
        for key, value in frame_values(self.sim.world).items():
            getattr(self.traj, key)[0] = value
        if self.contact_points_checkbox.value or self.contact_forces_checkbox.value:
            self._read_contacts()
        self._show_frame(0)

    def _read_contacts(self):
        c = self.sim.contacts()
        force = np.asarray(c.force, dtype=float).reshape(-1, 3)
        largest = float(np.max(np.linalg.norm(force, axis=1))) if len(force) else 0.0
        # the arrows' scale follows the largest recent force, fading after an impact
        self._force_max = max(largest, 0.97 * self._force_max)
        self.contacts = {"contact_point": np.asarray(c.point, dtype=float).reshape(1, -1, 3), "contact_force": force[None],
                         "force_max": self._force_max}

    # ---- what the viewer asks ---------------------------------------------------------------

    def _static_bodies(self) -> np.ndarray:
        # a disabled body is held fixed: static only if it comes back fixed
        return self.sim.world.body_types() == "fixed"

    def _shown(self, k: int) -> np.ndarray:
        """(N,) bool: the bodies in the simulation now (``World.disabled`` False, with a ``Switch``
        due at this time taken as done, as a recorded take shows it: ``Simulator.shown_disabled``):
        the others are hidden. NOTE: why: ``World.disabled`` alone showed a scene's ``enable_at``
        one frame later live than in the run's files (session 41's note)."""
        return ~np.asarray(self.sim.shown_disabled(), dtype=bool)

    def _contact_data(self) -> tuple[bool, bool, str]:
        w = self.sim.world
        colliding = bool(w.collisions) and any(shape is not None for shape in w.shapes)
        return colliding, colliding, "the live run"

    def _where(self, k: int) -> str:
        return f"step {self.sim.step_index}"

    def _status_text(self, k: int) -> str:
        line = f"t = {self.sim.world.t:.3f} s, step {self.sim.step_index}"
        if self._playing:
            line += f", {self.real_time_factor:.2f} x real time"
        frames = self._recorder.count
        line += f"\n\nrecorded {frames} frame{'s' if frames != 1 else ''}"
        if frames >= self._max_frames:
            line += " (full: the memory limit)"
        if self.saved:
            line += f"; saved {self.saved[-1]}"
        if self._mark is not None:
            line += f"; mark at t = {self._mark[0].t:.3f} s"
        if self.error is not None:
            line += f"\n\n**Stopped:** {self.error} (Reset to start again)"
        return line

    def _build_playback_gui(self, gui):
        with gui.add_folder("Live"):
            self.play_button = gui.add_button("Play")
            self.pause_button = gui.add_button("Pause", visible=False)
            self.step_button = gui.add_button("Step", hint=f"one frame: {self.steps_per_frame} steps of {self.sim.dt:g} s")
            self.reset_button = gui.add_button("Reset", hint=f"start {self.label} again")
            self.save_button = gui.add_button("Save", hint=f"write the run since the start to {self.out}/run-NNN/: "
                                                            "trajectory.npz and trajectory.glb")
            self.mark_button = gui.add_button("Mark", hint="remember this moment (a snapshot of the run)")
            self.back_button = gui.add_button("Back to mark", disabled=True,
                                              hint="return to the mark: try again from there (the take is cut back too)")
            self.speed_slider = gui.add_slider("Speed", min=0.05, max=4.0, step=0.05, initial_value=1.0,
                                               hint="simulated seconds per second, at most (a slow scene runs slower)")
            self.time_text = gui.add_markdown("")
        with gui.add_folder("Interact"):
            self.click_dropdown = gui.add_dropdown("Click a body to", CLICK_MODES, initial_value="select",
                                                   hint="select: its quantities; push: an impulse along the click; "
                                                        "grab: a spring to a handle you drag; blast: an explosion "
                                                        "where you click; pin: hold a body where it is, or let a "
                                                        "pinned one go; remove: take a body out (Back to mark or "
                                                        "Reset puts it back) (shift + click pushes)")
            self.push_speed_slider = gui.add_slider("Push speed (m/s)", min=0.1, max=20.0, step=0.1,
                                                    initial_value=PUSH_SPEED, hint="the speed a push gives the body")
            self.blast_radius_slider = gui.add_slider("Blast radius (m)", min=0.05, max=5.0, step=0.05,
                                                      initial_value=BLAST_RADIUS,
                                                      hint="a blast's full strength within it, fading over as far again")
            self.blast_strength_slider = gui.add_slider("Blast strength (N s/m^2)", min=10.0, max=5000.0, step=10.0,
                                                        initial_value=BLAST_IMPULSE,
                                                        hint="impulse per m^2 of each shape's shadow")
            self.blast_shaded_checkbox = gui.add_checkbox("Shaded blast", initial_value=False,
                                                          hint="bodies hidden from the blast by others are spared")
            self.release_button = gui.add_button("Release", visible=False, hint="let go of the grabbed body")

        if self._scene_dt is not None:
            from ..integrators import INTEGRATOR_IDS

            self._dt_choices = self._dt_options()
            with gui.add_folder("Integration"):
                self.integrator_dropdown = gui.add_dropdown(
                    "Integrator", tuple(INTEGRATOR_IDS), initial_value=self._scene_integrator,
                    hint="taken at the next Reset (docs/integrators.md)")
                self.dt_dropdown = gui.add_dropdown("dt", tuple(self._dt_choices),
                                                    initial_value=next(iter(k for k, v in self._dt_choices.items()
                                                                            if v == self._scene_dt)),
                                                    hint="the step, taken at the next Reset")
                gui.add_markdown("*Taken at the next Reset.*")
        self.camera_dropdown = self.camera_image = None
        if self.cameras:
            with gui.add_folder("Cameras"):
                self.camera_dropdown = gui.add_dropdown("Camera", ("(none)", *self.cameras), initial_value="(none)",
                                                        hint="one of the scene's cameras (tb.Camera.capture)")
                self.camera_kind = gui.add_dropdown("Image", ("colour", "depth"), initial_value="colour")
                self.camera_image = gui.add_image(np.zeros((2, 2, 3), np.uint8), visible=False)
            self.camera_dropdown.on_update(lambda _event: self._show_camera())
            self.camera_kind.on_update(lambda _event: self._show_camera())
        self.control_sliders = {}  # (robot, actuator or joint) -> slider
        controls = self._controls()
        if controls:
            with gui.add_folder("Controls"):
                for robot_name, name, what, low, high, value, hint in controls:
                    label = name if len(self.robots) == 1 else f"{robot_name}/{name}"
                    slider = gui.add_slider(f"{label} {what}".strip(), min=low, max=high, step=(high - low) / 200,
                                            initial_value=float(np.clip(value, low, high)), hint=hint)
                    slider.on_update(lambda _event, key=(robot_name, name): self._control_moved(key))
                    self.control_sliders[(robot_name, name)] = slider

        self._wire_play_pause()

        @self.step_button.on_click
        def _(_event):
            self.pause()
            self.step_frame()

        @self.reset_button.on_click
        def _(_event):
            try:
                self.reset()
            except InputError as err:  # the scene file changed, or an integrator it refuses: said, not raised
                self.time_text.content = self._status_text(0) + f"\n\n**Not reset:** {err}"

        @self.save_button.on_click
        def _(_event):
            try:
                self.save()
            except (OSError, InputError) as err:  # a full disk, a folder not writable: said, not raised
                self.time_text.content = self._status_text(0) + f"\n\n**Not saved:** {err}"

        @self.release_button.on_click
        def _(_event):
            self.release()

        @self.mark_button.on_click
        def _(_event):
            self.mark()

        @self.back_button.on_click
        def _(_event):
            self.back_to_mark()

    def _dt_options(self) -> dict:
        """{label: dt} of the steps offered: the scene's dt times ``DT_FACTORS`` that divide a frame
        into whole steps (the scene file's own check)."""
        from ..scene import _check_settings

        period = 1.0 / self.frame_rate
        options = {}
        for factor in DT_FACTORS:
            dt = self._scene_dt * factor
            try:
                _check_settings(1.0 / self.frame_rate, self.frame_rate, dt, "rk4", 1, 1.0, 1.0)
            except InputError:
                continue
            steps = int(round(period / dt))
            rate = 1.0 / dt
            text = f"1/{rate:.0f} s" if abs(rate - round(rate)) < 1e-9 * rate else f"{dt:.6g} s"
            label = f"{text}, {steps} a frame" + (" (the scene's)" if factor == 1.0 else "")
            options[label] = dt
        return options

    def _energy_data(self) -> tuple:
        """(t, kinetic, potential, total) of the last ``ENERGY_PLOT_FRAMES`` recorded frames."""
        rec = self._recorder
        k = rec.count
        first = max(0, k - ENERGY_PLOT_FRAMES)
        t = rec.arrays["time"][first:k].copy()
        kinetic = rec.arrays["kinetic_energy"][first:k].copy()
        potential = rec.arrays["potential_energy"][first:k].copy()
        return t, kinetic, potential, kinetic + potential

    def camera_frame(self) -> np.ndarray | None:
        """The image the "Cameras" folder shows now: (H, W, 3) uint8, the camera's ``rgb``, or its
        ``depth`` as grey (near white, far dark, nothing black); None when no camera is chosen."""
        if self.camera_dropdown is None or self.camera_dropdown.value == "(none)":
            return None
        with self._lock:
            image = self.cameras[self.camera_dropdown.value].capture(self.sim.world)
        if self.camera_kind.value == "colour":
            return image.rgb
        depth = image.depth
        seen = np.isfinite(depth)
        grey = np.zeros(depth.shape, np.uint8)
        if seen.any():
            near, far = float(depth[seen].min()), float(depth[seen].max())
            scale = (depth[seen] - near) / (far - near) if far > near else np.zeros(int(seen.sum()))
            grey[seen] = np.round(255 - 200 * scale).astype(np.uint8)
        return np.repeat(grey[..., None], 3, axis=2)

    def _show_camera(self):
        if self.camera_image is None:
            return
        frame = self.camera_frame()
        self.camera_image.visible = frame is not None
        if frame is not None:
            self.camera_image.image = frame

    def _plot_energy(self):
        self.energy_plot.data = self._energy_data()

    def _controls(self) -> list:
        """What the "Controls" folder offers: (robot, name, what, low, high, value, hint) rows.

        An MJCF model: each actuator (MuJoCo's viewer: its ctrl over its ctrlrange, -1 .. 1
        when unlimited). A robot without actuators (a URDF): each joint the scene drives, its
        velocity motor's speed (PyBullet's VELOCITY_CONTROL; over the URDF's velocity limit, else
        twice the speed given and at least 1) or its PD drive's target (POSITION_CONTROL; over the
        joint's limits, else a turn or a metre either way), with the scene's gains and force limits.
        """
        from ..joints import HingeJoint, P_MOTOR_ON, P_MOTOR_SPEED, P_STIFFNESS, P_TARGET

        rows = []
        for robot_name, robot in self.robots.items():
            if robot.actuators:
                for name, a in robot.actuators.items():
                    low, high = a.ctrlrange if a.ctrlrange is not None else (-1.0, 1.0)
                    rows.append((robot_name, name, "", float(low), float(high), a.ctrl,
                                 f"{a.kind} actuator on {a.joint or 'a tendon'}: its ctrl"))
                continue
            for name, record in robot.joints.items():
                p = getattr(getattr(record, "bound", None), "param", None)
                if p is None:
                    continue
                urdf = robot._urdf_joint(name)
                unit = "rad" if isinstance(record, HingeJoint) else "m"
                if p[P_MOTOR_ON]:
                    top = urdf.velocity or max(2.0 * abs(p[P_MOTOR_SPEED]), 1.0)
                    rows.append((robot_name, name, f"speed ({unit}/s)", -float(top), float(top), p[P_MOTOR_SPEED],
                                 "its velocity motor's speed (set_motor)"))
                elif p[P_STIFFNESS] > 0.0:
                    span = math.pi if unit == "rad" else 1.0
                    low = urdf.lower if urdf.lower is not None else min(-span, p[P_TARGET])
                    high = urdf.upper if urdf.upper is not None else max(span, p[P_TARGET])
                    rows.append((robot_name, name, f"target ({unit})", float(low), float(high), p[P_TARGET],
                                 "its PD drive's target (set_position_target)"))
        return rows

    def set_control(self, robot: str, name: str, value: float):
        """Set an MJCF actuator's control (MuJoCo's ``data.ctrl``; ``Robot.set_controls``), or a
        driven URDF joint's motor speed or drive target, from the next step on, as its slider
        in "Controls" does (the value clipped to the slider's range)."""
        slider = self.control_sliders.get((robot, name))
        if slider is None:
            raise InputError(f"no actuator or driven joint {name!r} of a robot {robot!r} in this scene", "controls")
        slider.value = float(np.clip(value, slider.min, slider.max))  # its callback sets the control

    def _control_moved(self, key):
        from ..joints import (P_DAMPING, P_MAX_DRIVE, P_MAX_MOTOR, P_MOTOR_ON, P_STIFFNESS)

        robot_name, name = key
        with self._lock:
            if self._internal_update:
                return
            robot, value = self.robots[robot_name], float(self.control_sliders[key].value)
            if robot.actuators:
                robot.set_controls(self.sim, {name: value})
                return
            p = robot.joints[name].bound.param
            if p[P_MOTOR_ON]:
                robot.set_motor(self.sim, name, value, max_force=float(p[P_MAX_MOTOR]))
            else:
                robot.set_position_target(self.sim, name, value, float(p[P_STIFFNESS]), float(p[P_DAMPING]),
                                          max_force=float(p[P_MAX_DRIVE]))

    def _show_controls(self):
        """Put each control slider at its control's value (after a reset: the scene's own)."""
        self._internal_update = True
        try:
            for robot_name, name, _what, _low, _high, value, _hint in self._controls():
                self.control_sliders[(robot_name, name)].value = float(value)
        finally:
            self._internal_update = False

    def _clicked(self, bodies: np.ndarray, event):
        mode = "push" if getattr(event, "modifier", None) == "shift" else self.click_dropdown.value
        if mode == "select":
            super()._clicked(bodies, event)
            return
        self.click_ray(event.ray_origin, event.ray_direction, mode)

    def click_ray(self, origin, direction, mode: str):
        """What a click along the ray ``origin`` + s ``direction`` (world) does in ``mode`` ("push",
        "grab", "blast", "pin", "remove", "select"): the first body the ray hits (``World.ray_cast``,
        the bodies' exact shapes), pushed along the ray at the hit point, grabbed there, blasted
        from there (``blast``: any body hit, the ground too, is where the explosion goes off),
        pinned or unpinned (``pin``), taken out (``remove``: not a plane), or selected. Returns the body's index, or None (nothing hit, or a
        body that does not move: only selected, or blasted from)."""
        if mode not in CLICK_MODES:
            raise InputError(f"expected one of {', '.join(CLICK_MODES)}, got {mode!r}", "mode")
        with self._lock:
            hits = self.sim.world.ray_cast(np.asarray(origin, float), np.asarray(direction, float))
            body = int(hits.body[0])
            if body < 0:
                if mode == "grab":
                    self._release_spring()
                return None
            self.select(body)
            if mode == "blast":
                self.blast(hits.point[0])
                return body if self.sim.world.moving[body] else None
            if mode == "pin":
                if not self._dynamic_at_start[body]:
                    return None
                self.pin(body)
                return body
            if mode == "remove":
                if isinstance(self.sim.world.shapes[body], Plane):
                    return None
                self.remove(body)
                return body
            if mode == "select" or not self.sim.world.moving[body]:
                return None
            if mode == "push":
                self.push(body, hits.point[0], direction)
            else:
                self.grab(body, hits.point[0])
            return body

    # ---- grabbing ---------------------------------------------------------------------------

    def _show_grab_handle(self, p):
        scale = max(0.15 * self.extent, 0.2)
        self.grab_handle = self.server.scene.add_transform_controls(
            "/grab", scale=scale, position=tuple(float(c) for c in p), disable_rotations=True, depth_test=False)

        @self.grab_handle.on_update
        def _(event):  # every phase of a drag (start, update, end) carries the handle's pose
            self.move_grab(np.asarray(event.target.position, dtype=float))

        self.release_button.visible = True

    def _release_spring(self):
        if self.grabbed is not None:
            _, spring, drag = self.grabbed
            self.grabbed = None
            self.sim.world.remove_force(spring)
            self.sim.world.remove_force(drag)
        if self.grab_handle is not None:
            handle, self.grab_handle = self.grab_handle, None
            handle.remove()
        self.release_button.visible = False
