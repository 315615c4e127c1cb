"""The interactive browser viewer: a viser server that plays a ``Trajectory``.

``view(traj_or_path)`` starts the server in background threads and returns a
``Viewer`` at once (``.url``, ``.stop()``); ``tumble view`` blocks on top of it.

What it shows (z up, metres, DESIGN.md's conventions):

* every body's mesh, tessellated from its shape record (``tumble.viewer.meshes``)
  and shifted by ``-com_offset``, so that it appears where the user put it while
  the body is posed at its centre of mass; planes are drawn as grids, and a
  ground grid lies in z = 0;
* instanced drawing: the bodies whose drawn meshes are identical (same vertices
  and faces) share one batched mesh node (``add_batched_meshes_simple``) with
  one row per body of positions, orientations and colours, so that a frame of a
  thousand equal boxes is two array messages to the browser, not two thousand;
  bodies that never move over the run are in groups of their own, never resent;
* GUI: Play / Pause, a frame slider to scrub, a speed factor, looping;
* picking: click a body (or choose it in the "Body" list) to see the course's
  quantities at the current frame: x, v, omega, P, L and its kinetic energy
  ``(v . P + omega . L) / 2``, beside the total kinetic and potential energy;
* an energy plot: the kinetic, potential and total energy of every frame (``tumble plot``'s
  first figure, in the page);
* toggles: body axes (a frame at each centre of mass, red/green/blue = body
  x/y/z; one batched axes node for all bodies, moved only while shown), contact
  points and contact forces, the ground grid (the contacts a trajectory may carry:
  ``tumble.viewer.contacts``);
* a body disabled at a frame (``World.set_enabled``: ``Trajectory.enabled`` False) is
  hidden there: its row of its group scaled to 0 (and its axes), sent only at the frames
  where some body vanishes or appears; its disabled frames are left out of the framing.

The server binds to 127.0.0.1 unless another ``host`` is given. If ``port`` is
busy, viser takes the next free one; ``Viewer.port`` and ``Viewer.url`` say
which (``port=0`` lets the system choose).
"""

from __future__ import annotations

import threading
import time as _time
import webbrowser
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..export.meshes import SENSOR_OPACITY, enabled_flags, sensor_flags
from ..trajectory import Trajectory, load_trajectory
from .. import visual
from .contacts import CONTACT_FORCE_COLOR, CONTACT_KEYS, CONTACT_POINT_COLOR, contact_arrays, contacts_at
from ..math3d import quat_to_matrix
from .meshes import MeshGroup, body_mesh, linear_colors, mesh_key

# a MuJoCo model (.xml) and a USD stage with physics are scenes of their own, as for tumble run
SCENE_SUFFIXES = (".toml", ".json", ".xml", ".usd", ".usda", ".usdc", ".usdz")
TRAJECTORY_SUFFIXES = (".npz",)

PALETTE = visual.PALETTE  # body colours shared with export and video
SELECTED_COLOR = (255, 215, 0)
PLANE_COLOR = (120, 120, 120)
PLAYBACK_TICK_S = 1.0 / 60.0
ENERGY_PLOT_POINTS = 10_000  # frames the energy plot takes at most (a longer run: every k-th)


def load_input(path, progress: bool | None = None) -> tuple[Trajectory, dict]:
    """A trajectory from ``path``: a ``.npz`` is read as is, a scene (``.toml``/``.json``) is run.

    Returns ``(trajectory, extras)`` where ``extras`` holds the optional contact
    arrays found in a ``.npz`` (``CONTACT_KEYS``). Bad input raises ``InputError``.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SCENE_SUFFIXES + TRAJECTORY_SUFFIXES:
        raise InputError(f"unknown file type {path.suffix!r} (expected a trajectory .npz or a scene .toml/.json/.xml/.usd*)", None, str(path))
    if not path.exists():
        raise InputError("file not found", None, str(path))
    if not path.is_file():
        raise InputError("not a file", None, str(path))
    if suffix in TRAJECTORY_SUFFIXES:
        traj = load_trajectory(path)
        extras = {}
        try:
            with np.load(path, allow_pickle=False) as data:
                extras = {k: np.asarray(data[k]) for k in CONTACT_KEYS if k in data.files}
        except (OSError, ValueError, KeyError):  # already read once by load_trajectory; extras are optional
            extras = {}
        return traj, extras
    from ..scene import load_scene

    scene = load_scene(path)
    return scene.run(progress=progress), {}


def view(traj_or_scene_path, host: str = "127.0.0.1", port: int = 8080, open_browser: bool = False,
         *, play: bool = True, progress: bool | None = None) -> Viewer:
    """Start the viewer on a ``Trajectory`` or a file (trajectory ``.npz``, scene ``.toml``/``.json``).

    Non-blocking: the server runs in background threads. Returns the ``Viewer``
    (``.url``, ``.stop()``, and handles such as ``.frame_slider``).

    Args:
        traj_or_scene_path: a ``Trajectory``, or a path (a scene is run first).
        host: address to bind; 127.0.0.1 (this machine only) unless asked.
        port: port to bind (the next free one if busy; 0: any free port).
        open_browser: open the page in the system's browser.
        play: start playing at once (False: paused at the first frame).
        progress: progress bar while a scene runs (None: tqdm's default).
    """
    if isinstance(traj_or_scene_path, Trajectory):
        traj, extras = traj_or_scene_path, {}
    elif isinstance(traj_or_scene_path, (str, Path)):
        traj, extras = load_input(traj_or_scene_path, progress=progress)
    else:
        raise InputError(f"expected a Trajectory or a file path, got {type(traj_or_scene_path).__name__}", "traj_or_scene_path")
    viewer = Viewer(traj, host=host, port=port, play=play, extras=extras)
    if open_browser:
        open_in_browser(viewer.url)
    return viewer


def open_in_browser(url: str):
    """Open ``url`` in the system's browser, if there is one (the URL is printed anyway)."""
    try:
        webbrowser.open(url)
    except (webbrowser.Error, OSError):  # no browser here: the URL is still there to copy
        pass


def _check_trajectory(traj: Trajectory):
    F, N = len(traj.time), len(traj.names)
    if F == 0:
        raise InputError("the trajectory has no frames", "time")
    for key, shape in (("position", (F, N, 3)), ("orientation", (F, N, 4)), ("com_offset", (N, 3))):
        value = np.shape(getattr(traj, key))
        if value != shape:
            raise InputError(f"expected shape {shape}, got {value}", key)


def check_address(host: str, port: int):
    """Raise ``InputError`` unless ``host`` is an address of this machine and ``port`` a port number.

    viser retries the next port on any bind error and never returns when none
    works (an unknown host name), so the address is tried here first.
    """
    import socket

    if not isinstance(port, int) or isinstance(port, bool) or not 0 <= port <= 65535:
        raise InputError(f"must be a port number between 0 and 65535, got {port!r}", "port")
    try:
        infos = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:
        raise InputError(f"cannot resolve host {host!r} ({exc})", "host") from None
    family, _, _, _, sockaddr = infos[0]
    try:
        with socket.socket(family, socket.SOCK_STREAM) as sock:
            sock.bind(sockaddr[:2] if family == socket.AF_INET else sockaddr)
    except OSError as exc:
        raise InputError(f"cannot bind to host {host!r} ({exc.strerror or exc})", "host") from None


def _fmt(v) -> str:
    return " | ".join(f"{float(c):+.4g}" for c in v)


class Viewer:
    """A running viewer. Use ``view()`` to make one; ``stop()`` ends it.

    Attributes:
        server: the ``viser.ViserServer``.
        url: the page's address.  host, port: where the server is bound.
        frame_slider, speed_slider, play_button, pause_button, loop_checkbox,
        axes_checkbox, contact_points_checkbox, contact_forces_checkbox,
        grid_checkbox, body_dropdown, info: the GUI handles.
        mesh_groups: the ``MeshGroup``s, one batched mesh node each (all bodies but planes).
        plane_frames: {body index: scene frame posed at its centre of mass} for plane bodies.
        axes_node: the batched axes node of all bodies (hidden unless "Body axes" is on).
        enabled: (F, N) bool, the trajectory's ``enabled`` (a body is hidden where False).
        ``body_pose(i)``, ``body_color(i)`` and ``body_shown(i)`` read what was sent to the
        browser for body i.
    """

    def __init__(self, traj: Trajectory, host: str = "127.0.0.1", port: int = 8080, *, play: bool = True,
                 extras: dict | None = None):
        import viser

        _check_trajectory(traj)
        self.traj = traj
        self.time = np.asarray(traj.time, dtype=float)
        self.position = np.asarray(traj.position, dtype=float)
        self.orientation = np.asarray(traj.orientation, dtype=float)
        self.names = [str(n) for n in np.asarray(traj.names)]
        self.enabled = enabled_flags(traj)
        self.frame_count = len(self.time)
        self.body_count = len(self.names)
        self.contacts = contact_arrays(traj, extras or {})

        self._lock = threading.RLock()
        self._stop_event = threading.Event()
        self._stopped = False
        self._frame = 0
        self._selected: int | None = None
        self._internal_update = False
        self._playing = False
        self._t = float(self.time[0])

        check_address(host, port)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.host = self.server.get_host()
        self.port = self.server.get_port()
        try:
            self._build_scene()
            self._build_gui()
            self._show_frame(0)
        except BaseException:
            self.server.stop()
            raise
        if play and self.frame_count > 1:
            self.play()
        self._thread = threading.Thread(target=self._playback_loop, name="tumble-viewer-playback", daemon=True)
        self._thread.start()

    # ---- public API -------------------------------------------------------------------------

    @property
    def url(self) -> str:
        host = self.host
        if host in ("0.0.0.0", "", "::"):
            host = "127.0.0.1"
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    @property
    def frame(self) -> int:
        """The frame shown now."""
        return self._frame

    @property
    def playing(self) -> bool:
        return self._playing

    @property
    def selected(self) -> int | None:
        """Index of the picked body, or None."""
        return self._selected

    def set_frame(self, k: int):
        """Show frame ``k`` (as moving the slider does)."""
        self.frame_slider.value = int(np.clip(k, 0, self.frame_count - 1))

    def play(self):
        with self._lock:
            if self._frame >= self.frame_count - 1 and not self.loop_checkbox.value:
                self._t = float(self.time[0])
            self._playing = True
        self.play_button.visible = False
        self.pause_button.visible = True

    def pause(self):
        self._playing = False
        self.play_button.visible = True
        self.pause_button.visible = False

    def select(self, index: int | None):
        """Pick body ``index`` (None: none): highlight it and show its quantities."""
        with self._lock:
            old = self._selected
            self._selected = None if index is None else int(index)
            if old is not None and old != self._selected:
                self._paint(old, self.colors[old])
            if self._selected is not None:
                self._paint(self._selected, SELECTED_COLOR)
            label = "(none)" if self._selected is None else self._body_label(self._selected)
            if self.body_dropdown.value != label:
                self._internal_update = True
                try:
                    self.body_dropdown.value = label
                finally:
                    self._internal_update = False
            self._update_info()

    def body_info(self, i: int, k: int | None = None) -> dict:
        """The course's quantities of body ``i`` at frame ``k`` (default: the frame shown)."""
        k = self._frame if k is None else k
        t = self.traj
        v = np.asarray(t.velocity[k, i], float)
        w = np.asarray(t.angular_velocity[k, i], float)
        P = np.asarray(t.linear_momentum[k, i], float)
        L = np.asarray(t.angular_momentum[k, i], float)
        return {
            "name": self.names[i], "frame": k, "time": float(self.time[k]),
            "x": self.position[k, i], "q": self.orientation[k, i], "v": v, "omega": w, "P": P, "L": L,
            "kinetic_energy": 0.5 * float(v @ P + w @ L),
            "kinetic_energy_total": float(t.kinetic_energy[k]),
            "potential_energy_total": float(t.potential_energy[k]),
        }

    def body_pose(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,), wxyz (4,)) of body ``i`` as last sent to the browser: its centre of mass
        in world coordinates (m) and its orientation (body to world), float64 copies of the
        batched arrays (float32 on the wire)."""
        i = int(i)
        g = self._group_of[i]
        if g < 0:
            frame = self.plane_frames[i]
            return np.array(frame.position, float), np.array(frame.wxyz, float)
        handle, j = self.mesh_groups[g].handle, self._row_of[i]
        return np.array(handle.batched_positions[j], float), np.array(handle.batched_wxyzs[j], float)

    def body_color(self, i: int) -> tuple[int, int, int] | None:
        """sRGB colour (0-255) body ``i`` is drawn in now, the highlight if selected (None for planes).

        The browser is sent ``linear_colors`` of it (``mesh_groups[g].handle.batched_colors``).
        """
        g = self._group_of[int(i)]
        if g < 0:
            return None
        return tuple(int(c) for c in self.mesh_groups[g].colors[self._row_of[int(i)]])

    def body_shown(self, i: int) -> bool:
        """Whether body ``i`` is drawn now, as last sent to the browser: False while it is disabled
        (its row's scale 0; a plane's frame hidden)."""
        i = int(i)
        g = self._group_of[i]
        if g < 0:
            return bool(self.plane_frames[i].visible)
        scales = self.mesh_groups[g].handle.batched_scales
        return scales is None or bool(np.all(scales[self._row_of[i]] > 0))

    def stop(self):
        """Stop playback and the server (idempotent)."""
        if self._stopped:
            return
        self._stopped = True
        self._stop_event.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self.server.stop()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

    # ---- scene ------------------------------------------------------------------------------

    def _body_label(self, i: int) -> str:
        return f"{i}: {self.names[i]}"

    def _build_scene(self):
        scene = self.server.scene
        scene.set_up_direction("+z")
        N = self.body_count
        fixed = np.zeros(N, bool) if self.traj.fixed is None else np.asarray(self.traj.fixed, bool)
        # the exporters' and the video's rule (palette by body index, fixed bodies grey): a body
        # looks the same here as in the .glb, the .usd, the web page and the video
        self.colors = [tuple(int(v) for v in c) for c in visual.palette_colors(fixed)]
        sensor = sensor_flags(self.traj)
        com_offset = np.asarray(self.traj.com_offset, float)
        static = self._static_bodies()

        # Tessellate each distinct (shape record, com_offset) once: a pile of equal boxes is one mesh,
        # not N (trimesh's creation functions cost ~0.1 ms each).
        meshes: dict = {}  # (shape text, com_offset bytes) -> (vertices, faces, digest, radius, is_plane, shape)
        group_of_key: dict = {}  # (geometry digest, static, sensor, open mesh) -> list of body indices
        self.plane_frames, self.plane_nodes = {}, []
        self._group_of = np.full(N, -1, dtype=np.int64)  # body -> index in mesh_groups (-1: plane)
        self._row_of = np.full(N, -1, dtype=np.int64)  # body -> row in its group's arrays
        radii = np.zeros(N)
        is_plane = np.zeros(N, bool)
        geometry_of_digest = {}
        for i in range(N):
            text = self.traj.shape_text(i)
            key = (text, com_offset[i].tobytes())
            if key not in meshes:
                shape = self.traj.shape(i)
                plane = shape is not None and type(shape).__name__ == "Plane"
                if plane:
                    meshes[key] = (None, None, None, 0.0, True, shape)
                else:
                    geometry = body_mesh(shape, com_offset[i]) if shape is not None else None
                    if geometry is None:  # no shape recorded (old file): a marker ball
                        m = visual.shape_trimesh(None)
                        geometry = (np.asarray(m.vertices, float), np.asarray(m.faces, np.int64))
                    vertices = np.ascontiguousarray(geometry[0], dtype=float)
                    faces = np.ascontiguousarray(geometry[1], dtype=np.int64)
                    # Two records may draw the same mesh (equal boxes written with different names
                    # or key orders): grouping is by the drawn arrays' bytes, not by the record.
                    digest = mesh_key(vertices, faces)
                    geometry_of_digest.setdefault(digest, (vertices, faces))
                    radius = float(np.max(np.linalg.norm(vertices, axis=1))) if len(vertices) else 0.0
                    meshes[key] = (vertices, faces, digest, radius, False, shape)
            _, _, digest, radii[i], is_plane[i], shape = meshes[key]
            if is_plane[i]:
                self.plane_frames[i] = scene.add_frame(f"/bodies/b{i}", show_axes=False,
                                                       position=self.position[0, i], wxyz=self.orientation[0, i])
                plane = self._add_plane(i, shape, com_offset[i])
                if plane is not None:
                    self.plane_nodes.append(plane)
                continue
            # an open mesh (Mesh(closed=False)) collides on both sides: draw both
            sheet = getattr(shape, "closed", True) is False
            group_of_key.setdefault((digest, bool(static[i]), bool(sensor[i]), sheet), []).append(i)

        self.mesh_groups = []
        colors = np.asarray(self.colors, dtype=np.uint8).reshape(N, 3)
        for g, ((digest, group_static, group_sensor, sheet), members) in enumerate(group_of_key.items()):
            vertices, faces = geometry_of_digest[digest]
            bodies = np.asarray(members, dtype=np.int64)
            self._group_of[bodies] = g
            self._row_of[bodies] = np.arange(len(bodies))
            consecutive = bodies[-1] - bodies[0] == len(bodies) - 1
            rows = slice(int(bodies[0]), int(bodies[-1]) + 1) if consecutive else bodies
            group_colors = colors[bodies].copy()
            handle = scene.add_batched_meshes_simple(
                f"/bodies/g{g}", vertices, faces, self.orientation[0, rows], self.position[0, rows],
                batched_colors=linear_colors(group_colors), flat_shading=len(faces) <= 24,
                side="double" if sheet else "front",
                # sensors translucent, so what they hold shows
                opacity=SENSOR_OPACITY if group_sensor else None)
            # The browser says which instance was clicked: row j of this group is body bodies[j].
            handle.on_click(lambda event, bodies=bodies: self._clicked(bodies, event))
            self.mesh_groups.append(MeshGroup(handle, bodies, group_static, group_colors, rows))
        self._moving_groups = [group for group in self.mesh_groups if not group.static]
        self._moving_planes = [i for i in self.plane_frames if not static[i]]

        # Body axes: one batched node for all bodies (a per-body frame would be N nodes and N
        # messages a frame again). Unit axes scaled per body, so the radius keeps 3 % of the length.
        lengths = np.where(radii > 0, np.maximum(1.4 * radii, 0.1), 0.3)
        self.axes_node = scene.add_batched_axes("/bodies/axes", self.orientation[0], self.position[0],
                                                batched_scales=lengths, axes_length=1.0, axes_radius=0.03,
                                                visible=False)
        self.axes_node.on_click(lambda event: self._clicked(np.arange(N), event))
        self._axes_frame = 0  # the frame the axes were last posed at
        self._axes_lengths = lengths
        self.body_radius = radii
        # what the nodes were made with: every body drawn (_show_presence hides the disabled ones)
        self._shown_sent = np.ones(N, dtype=bool)

        # Size of the scene: the centres of mass over the whole run, widened by the bodies, at the
        # frames they are drawn (all frames, when that leaves nothing).
        moving = [i for i in range(self.body_count) if not is_plane[i]]
        if moving:
            shown = self.enabled[:, moving]
            pts = self.position[:, moving, :][shown] if shown.any() else self.position[:, moving, :].reshape(-1, 3)
            pts = pts[np.all(np.isfinite(pts), axis=1)]
        else:
            pts = np.zeros((1, 3))
        if len(pts) == 0:
            pts = np.zeros((1, 3))
        r = float(np.max(radii)) if len(radii) else 0.0
        lo, hi = pts.min(axis=0) - r, pts.max(axis=0) + r
        self.center = 0.5 * (lo + hi)
        self.extent = float(max(np.max(hi - lo), 0.5))

        grid_size = float(max(10.0, 2.0 * np.ceil(max(np.max(np.abs(lo[:2])), np.max(np.abs(hi[:2]))) + 1.0)))
        self.grid = scene.add_grid("/ground", width=grid_size, height=grid_size, plane="xy",
                                   cell_size=0.1 if grid_size <= 10 else grid_size / 100, section_size=1.0,
                                   cell_color=(200, 200, 200), section_color=(140, 140, 140))

        direction = np.array([1.0, -1.6, 0.9])
        direction /= np.linalg.norm(direction)
        self.server.initial_camera.look_at = tuple(self.center)
        self.server.initial_camera.position = tuple(self.center + direction * (0.9 * self.extent + 0.5))
        self.server.initial_camera.up = (0.0, 0.0, 1.0)

        self.contact_points_node = None
        self.contact_forces_node = None

    def _static_bodies(self) -> np.ndarray:
        """(N,) bool: the bodies that keep their pose over the whole run (posed once, in groups of
        their own kind)."""
        return np.all(self.position == self.position[:1], axis=(0, 2)) \
            & np.all(self.orientation == self.orientation[:1], axis=(0, 2))

    def _clicked(self, bodies: np.ndarray, event):
        """A click on a batched node whose row j is body ``bodies[j]`` (viser's pointer event)."""
        self._pick(bodies, event.instance_index)

    def _pick(self, bodies: np.ndarray, instance_index: int | None):
        """A click on instance ``instance_index`` of a batched node whose row j is body ``bodies[j]``."""
        if instance_index is None or not 0 <= int(instance_index) < len(bodies):
            return  # the browser did not say which instance (an older client): nothing picked
        self.select(int(bodies[int(instance_index)]))

    def _paint(self, i: int, color):
        """Send body ``i``'s colour (sRGB 0-255): its group's whole colour array, one message."""
        g = self._group_of[i]
        if g < 0:
            return  # planes are grids: not highlighted
        group = self.mesh_groups[g]
        group.colors[self._row_of[i]] = color
        group.handle.batched_colors = linear_colors(group.colors)

    def _shown(self, k: int) -> np.ndarray:
        """(N,) bool: the bodies drawn at frame ``k``, those enabled (``Trajectory.enabled``)."""
        return self.enabled[k]

    def _show_presence(self, k: int):
        """Hide the bodies not drawn at frame ``k`` and show the others again: a hidden body's
        row of its group (and of the axes) scaled to 0. Only the groups where some body changed
        since the last call are sent (nothing at all for a run where no body is ever disabled)."""
        shown = np.asarray(self._shown(k), dtype=bool)
        changed = shown != self._shown_sent
        if not changed.any():
            return
        for g in np.unique(self._group_of[changed]):
            if g >= 0:
                group = self.mesh_groups[g]
                group.handle.batched_scales = shown[group.bodies].astype(np.float32)
        for i in np.flatnonzero(changed):
            if i in self.plane_frames:
                self.plane_frames[i].visible = bool(shown[i])
        self.axes_node.batched_scales = self._axes_lengths * shown
        self._shown_sent = shown.copy()

    def _pose_axes(self, k: int):
        """Pose every body's axes at frame ``k`` (one message)."""
        self.axes_node.batched_positions = self.position[k]
        self.axes_node.batched_wxyzs = self.orientation[k]
        self._axes_frame = k

    def _add_plane(self, i, shape, com_offset):
        """A plane body: a translucent grid in the plane, centred on the foot of the shape origin.

        A plane that is the ground z = 0 (normal +z) is left to the ground grid (None).
        """
        n = np.asarray(shape.normal, float)
        foot = n * float(shape.offset) - np.asarray(com_offset, float)
        q = np.asarray(self.orientation[0, i], float)
        R = quat_to_matrix(q / np.linalg.norm(q))
        if (R @ n)[2] > 1 - 1e-9 and abs((self.position[0, i] + R @ foot)[2]) < 1e-9:
            return None
        zhat = np.array([0.0, 0.0, 1.0])
        axis = np.cross(zhat, n)
        s, c = np.linalg.norm(axis), float(zhat @ n)
        if s < 1e-12:
            wxyz = (1.0, 0.0, 0.0, 0.0) if c > 0 else (0.0, 1.0, 0.0, 0.0)
        else:
            angle = np.arctan2(s, c)
            axis = axis / s
            wxyz = (np.cos(angle / 2), *(np.sin(angle / 2) * axis))
        return self.server.scene.add_grid(f"/bodies/b{i}/plane", width=20.0, height=20.0, plane="xy",
                                          position=foot, wxyz=wxyz, plane_color=PLANE_COLOR, plane_opacity=0.25,
                                          cell_size=0.5, section_size=2.0)

    def _draw_contacts(self, k: int):
        scene = self.server.scene
        points, forces = contacts_at(self.contacts, k)
        show_points = self.contact_points_checkbox.value and len(points) > 0
        if show_points:
            self.contact_points_node = scene.add_point_cloud(
                "/contacts/points", points, CONTACT_POINT_COLOR, point_size=max(0.01 * self.extent, 0.01),
                point_shape="circle")
        elif self.contact_points_node is not None:
            self.contact_points_node.remove()
            self.contact_points_node = None
        show_forces = self.contact_forces_checkbox.value and forces is not None and len(points) > 0 \
            and self.contacts.get("force_max", 0.0) > 0.0
        if show_forces:
            scale = 0.25 * self.extent / self.contacts["force_max"]
            segments = np.stack([points, points + scale * forces], axis=1)
            width = max(0.004 * self.extent, 0.004)
            self.contact_forces_node = scene.add_arrows(
                "/contacts/forces", segments, CONTACT_FORCE_COLOR, shaft_radius=width, head_radius=2.5 * width,
                head_length=6 * width)
        elif self.contact_forces_node is not None:
            self.contact_forces_node.remove()
            self.contact_forces_node = None

    # ---- GUI --------------------------------------------------------------------------------

    def _build_gui(self):
        gui = self.server.gui
        self._build_playback_gui(gui)
        with gui.add_folder("Energy"):
            import viser.uplot as uplot

            self.energy_plot = gui.add_uplot(
                data=self._energy_data(),
                series=(uplot.Series(label="t (s)"), uplot.Series(label="kinetic (J)", stroke="#d62728", width=1.5),
                        uplot.Series(label="potential (J)", stroke="#1f77b4", width=1.5),
                        uplot.Series(label="total (J)", stroke="#2ca02c", width=2)),
                scales={"x": uplot.Scale(time=False)}, title="kinetic, potential and total energy", aspect=1.6)
        with gui.add_folder("Show"):
            self.axes_checkbox = gui.add_checkbox("Body axes", initial_value=False,
                                                  hint="a frame at each centre of mass: red x, green y, blue z (body axes)")
            has_points, has_forces, source = self._contact_data()
            self.contact_points_checkbox = gui.add_checkbox(
                "Contact points", initial_value=has_points,
                hint=f"from {source}'s contact_point" if has_points else f"{source} has no contact data")
            self.contact_forces_checkbox = gui.add_checkbox(
                "Contact forces", initial_value=has_forces,
                hint=f"from {source}'s contact_force" if has_forces else f"{source} has no contact forces")
            self.grid_checkbox = gui.add_checkbox("Ground grid", initial_value=True)
            if not has_points:
                gui.add_markdown(f"*No contact data in {source}.*")
        with gui.add_folder("Body"):
            options = ["(none)"] + [self._body_label(i) for i in range(self.body_count)]
            self.body_dropdown = gui.add_dropdown("Body", options, initial_value="(none)",
                                                  hint="or click a body in the scene")
            self.info = gui.add_markdown("*Click a body to see its quantities.*")

        @self.axes_checkbox.on_update
        def _(_event):
            visible = bool(self.axes_checkbox.value)
            with self._lock, self.server.atomic():
                if visible and self._axes_frame != self._frame:  # not moved while hidden
                    self._pose_axes(self._frame)
                self.axes_node.visible = visible

        @self.contact_points_checkbox.on_update
        def _(_event):
            with self._lock:
                self._draw_contacts(self._frame)

        @self.contact_forces_checkbox.on_update
        def _(_event):
            with self._lock:
                self._draw_contacts(self._frame)

        @self.grid_checkbox.on_update
        def _(_event):
            self.grid.visible = bool(self.grid_checkbox.value)

        @self.body_dropdown.on_update
        def _(_event):
            if self._internal_update:
                return
            value = self.body_dropdown.value
            self.select(None if value == "(none)" else int(value.split(":", 1)[0]))

    def _wire_play_pause(self):
        self.play_button.on_click(lambda _event: self.play())
        self.pause_button.on_click(lambda _event: self.pause())

    def _energy_data(self) -> tuple:
        """(t, kinetic, potential, total) (F,) of the run's frames for the energy plot (at most
        ``ENERGY_PLOT_POINTS``: a longer run every k-th frame, its last frame kept)."""
        F = self.frame_count
        rows = np.arange(F) if F <= ENERGY_PLOT_POINTS else np.unique(np.r_[np.arange(0, F, -(-F // ENERGY_PLOT_POINTS)), F - 1])
        kinetic = np.asarray(self.traj.kinetic_energy, float)[rows]
        potential = np.asarray(self.traj.potential_energy, float)[rows]
        return self.time[rows].copy(), kinetic, potential, kinetic + potential

    def _contact_data(self) -> tuple[bool, bool, str]:
        """(contact points to draw, contact forces to draw, what they come from) for the toggles."""
        return "contact_point" in self.contacts, "contact_force" in self.contacts, "this trajectory"

    def _build_playback_gui(self, gui):
        """The "Playback" folder: play, pause, the frame slider, speed, looping, the time."""
        F = self.frame_count
        with gui.add_folder("Playback"):
            self.play_button = gui.add_button("Play", icon=None)
            self.pause_button = gui.add_button("Pause", visible=False)
            self.frame_slider = gui.add_slider("Frame", min=0, max=max(F - 1, 1), step=1, initial_value=0,
                                               disabled=F < 2)
            self.speed_slider = gui.add_slider("Speed", min=0.05, max=4.0, step=0.05, initial_value=1.0,
                                               hint="playback speed, times real time")
            self.loop_checkbox = gui.add_checkbox("Loop", initial_value=True)
            self.time_text = gui.add_markdown("")
        self._wire_play_pause()

        @self.frame_slider.on_update
        def _(_event):
            k = int(np.clip(int(self.frame_slider.value), 0, F - 1))
            with self._lock:
                if not self._internal_update:  # scrubbed by the user: playback continues from here
                    self._t = float(self.time[k])
                self._show_frame(k)

    # ---- frames -----------------------------------------------------------------------------

    def _show_frame(self, k: int):
        with self._lock:
            self._frame = k
            with self.server.atomic():
                # One assignment per array and group: one message each, whatever the number of bodies.
                for group in self._moving_groups:
                    group.handle.batched_positions = self.position[k, group.rows]
                    group.handle.batched_wxyzs = self.orientation[k, group.rows]
                for i in self._moving_planes:
                    self.plane_frames[i].position = self.position[k, i]
                    self.plane_frames[i].wxyz = self.orientation[k, i]
                if self.axes_checkbox.value:  # hidden axes are not moved (posed when shown again)
                    self._pose_axes(k)
                self._show_presence(k)
                self._draw_contacts(k)
            self.time_text.content = self._status_text(k)
            self._update_info()

    def _where(self, k: int) -> str:
        """Where frame ``k`` is in the run, for the body panel."""
        return f"frame {k}"

    def _status_text(self, k: int) -> str:
        return f"t = {self.time[k]:.3f} s, frame {k} of {self.frame_count - 1}"

    def _update_info(self):
        i = self._selected
        if i is None:
            self.info.content = "*Click a body to see its quantities.*"
            return
        d = self.body_info(i)
        rows = [("x (m)", d["x"]), ("v (m/s)", d["v"]), ("ω (rad/s)", d["omega"]),
                ("P (kg m/s)", d["P"]), ("L (kg m²/s)", d["L"])]
        lines = [f"**{d['name']}** at t = {d['time']:.3f} s ({self._where(d['frame'])})", "",
                 "| | x | y | z |", "|:--|--:|--:|--:|"]
        if not self._shown(d["frame"])[i]:
            lines[1:1] = ["", "*Disabled here (hidden): out of the simulation.*"]
        lines += [f"| {label} | {_fmt(vec)} |" for label, vec in rows]
        lines += ["", f"Kinetic energy: {d['kinetic_energy']:.6g} J (all bodies: {d['kinetic_energy_total']:.6g} J)", "",
                  f"Potential energy, all bodies: {d['potential_energy_total']:.6g} J"]
        self.info.content = "\n".join(lines)

    def _playback_loop(self):
        last = _time.monotonic()
        while not self._stop_event.wait(PLAYBACK_TICK_S):
            now = _time.monotonic()
            elapsed, last = now - last, now
            if not self._playing or self.frame_count < 2:
                continue
            try:
                with self._lock:
                    t0, t1 = float(self.time[0]), float(self.time[-1])
                    self._t += elapsed * float(self.speed_slider.value)
                    if self._t > t1:
                        if self.loop_checkbox.value and t1 > t0:
                            self._t = t0 + (self._t - t1) % (t1 - t0 + self._frame_period())
                        else:
                            self._t = t1
                            self._playing = False
                    k = int(np.clip(np.searchsorted(self.time, self._t, side="right") - 1, 0, self.frame_count - 1))
                    if k != self._frame:
                        self._internal_update = True
                        try:
                            self.frame_slider.value = k
                        finally:
                            self._internal_update = False
                if not self._playing:
                    self.pause()
            except Exception:  # the server was stopped under us
                if self._stop_event.is_set():
                    return
                raise

    def _frame_period(self) -> float:
        return float(np.median(np.diff(self.time))) if self.frame_count > 1 else 0.0
