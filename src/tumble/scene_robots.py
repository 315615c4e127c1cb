"""Scene files: the ``[[robots]]`` entries, URDF files (``tumble.urdf``) and MuJoCo MJCF files
(``.xml``, ``tumble.mjcf``) loaded into the scene.

::

    [[robots]]
    file = "arm.urdf"              # required; relative to the scene file's folder
    name = "arm"                   # default: the URDF's <robot name>; bodies are "arm/<link>"
    position = [0, 0, 0]           # the root link's frame
    euler_deg = [0, 0, 90]         # or orientation = [w, x, y, z]
    fixed_base = true              # default false (a root link without mass is fixed anyway)
    merge_fixed = true             # fuse links joined by fixed joints (default true)
    self_collision = false         # default false
    inertia = "file"               # "file" (default), "balance" or "shapes"
    joint_positions = { shoulder = 0.5, elbow = -1.0 }   # rad or m, by URDF joint name
    joint_motors = { yaw = { speed = 1.5, max_force = 20 } }             # velocity motors
    joint_targets = { elbow = { position = 0.9, stiffness = 200, damping = 20 } }   # PD drives
    joint_torques = { wrist = 0.5 }                                     # N m (N: prismatic), applied
    package_dirs = ["ros/src"]     # where package:// meshes are looked up (scene-relative)
    material = { friction = 0.8 }  # links without Bullet's <contact>
    collision_filter = { category = 2 }

An ``.xml`` file is read as MJCF (``load_mjcf``): ``fixed_base``, ``merge_fixed`` and ``package_dirs``
do not apply to it, and ``self_collision`` defaults to true (MuJoCo's rule); ``controls = { name =
ctrl }`` sets its actuators' controls (MuJoCo's ``data.ctrl``, ``Robot.set_controls``) for the run,
and ``keyframe = "home"`` starts it in a ``<keyframe>`` key (``Robot.reset_to_keyframe``);
``world_geoms = false`` leaves off the file's ``<worldbody>`` geoms (its floor, when the scene has a ground);
``margins = true`` reads its geoms' ``margin`` (``load_mjcf(margins=)``).

A USD stage (``.usd``, ``.usda``, ``.usdc``, ``.usdz``) is read by ``usd_physics.load_usd``: its
rigid bodies, colliders and joints (the UsdPhysics schema), named ``NAME/<prim path>`` when ``name``
is given, placed by ``position`` and ``orientation`` or ``euler_deg``; it takes no other key (its
bodies' materials and filters are the stage's).

A problem inside the URDF file is one line naming both files:
``scene.toml: robots[0].file: arm.urdf: joint[elbow].limit.lower: expected 1 number, got 'x'``.
"""

from __future__ import annotations

from pathlib import Path

from .collision.filter import FILTER_KEYS, CollisionFilter
from .errors import InputError
from .mjcf import load_mjcf
from .usd_physics import USD_SUFFIXES, load_usd
from .urdf import INERTIA_SOURCES, load_urdf

URDF_ONLY = ("fixed_base", "merge_fixed", "package_dirs")

ROBOT_KEYS = ("file", "name", "position", "orientation", "euler_deg", "fixed_base", "merge_fixed", "self_collision",
              "inertia", "joint_positions", "joint_motors", "joint_targets", "joint_torques", "controls",
              "keyframe", "package_dirs", "material", "collision_filter", "world_geoms", "margins")


class RobotReader:
    """Mixed into the scene parser (a ``BodyReader``: ``data_path``, ``material``...): one ``[[robots]]`` entry."""

    def robot(self, world, entry: dict, key: str, names: dict):
        self.table(entry, key, ROBOT_KEYS, required=("file",))
        if str(entry["file"]).lower().endswith(USD_SUFFIXES):
            return self._usd(world, entry, key, names)
        mjcf = str(entry["file"]).lower().endswith(".xml")
        path = Path(self.data_path(entry["file"], f"{key}.file", "MJCF" if mjcf else "URDF"))
        if mjcf:
            for k in URDF_ONLY:
                if k in entry:
                    raise self.error("a URDF option: an MJCF (.xml) model does not take it", f"{key}.{k}")
        elif "controls" in entry:
            raise self.error("an MJCF option (actuator controls): a URDF has no actuators", f"{key}.controls")
        elif "keyframe" in entry:
            raise self.error("an MJCF option (a <keyframe> key): a URDF has no keyframes", f"{key}.keyframe")
        elif "world_geoms" in entry:
            raise self.error("an MJCF option (the <worldbody>'s own geoms): a URDF has none", f"{key}.world_geoms")
        elif "margins" in entry:
            raise self.error("an MJCF option (its geoms' margins): a URDF has none", f"{key}.margins")
        settings = {}  # applied to the loaded robot: {option: {name: number}}
        for k in ("joint_torques", "controls"):
            if k in entry:
                table = self.table(entry[k], f"{key}.{k}", entry[k].keys() if isinstance(entry[k], dict) else ())
                settings[k] = {n: self.number(v, f"{key}.{k}.{n}") for n, v in table.items()}
        kw = self._name_and_pose(entry, key)
        for k in ("fixed_base", "merge_fixed", "self_collision", "world_geoms", "margins"):
            if k in entry:
                kw[k] = self.boolean(entry[k], f"{key}.{k}")
        if "inertia" in entry:
            kw["inertia"] = self.string(entry["inertia"], f"{key}.inertia", INERTIA_SOURCES)
        if "keyframe" in entry:
            kw["keyframe"] = self.string(entry["keyframe"], f"{key}.keyframe")
        if "joint_positions" in entry:
            table = self.table(entry["joint_positions"], f"{key}.joint_positions", entry["joint_positions"].keys()
                               if isinstance(entry["joint_positions"], dict) else ())
            kw["joint_positions"] = {j: self.number(v, f"{key}.joint_positions.{j}") for j, v in table.items()}
        for k in ("joint_motors", "joint_targets"):
            if k in entry:  # tables of tables; their keys and numbers are checked by load_urdf
                kw[k] = self.table(entry[k], f"{key}.{k}", entry[k].keys() if isinstance(entry[k], dict) else (),
                                   what="a table of joint names")
        if "package_dirs" in entry:
            dirs = entry["package_dirs"]
            if not isinstance(dirs, list):
                raise self.error(f"expected a list of folders, got {dirs!r}", f"{key}.package_dirs")
            kw["package_dirs"] = [self.base_dir / self.string(d, f"{key}.package_dirs[{i}]") for i, d in enumerate(dirs)]
        if "material" in entry:
            kw["material"] = self.material(entry["material"], f"{key}.material")
        if "collision_filter" in entry:
            f = self.table(entry["collision_filter"], f"{key}.collision_filter", FILTER_KEYS)
            kw["collision_filter"] = self.library(f"{key}.collision_filter", CollisionFilter, **f)
        self.where = key
        before = world.body_count
        try:
            robot = (load_mjcf if mjcf else load_urdf)(world, path, **kw)
        except InputError as err:
            if err.file:  # the URDF's own problem: both files on the line
                inner = ": ".join(str(p) for p in (Path(err.file).name, err.key) if p)
                raise self.error(f"{inner}: {err.problem}", f"{key}.file") from None
            raise err.within(key, self.file) from None
        for option, values in settings.items():
            for name, value in values.items():
                try:
                    if option == "joint_torques":
                        robot.set_joint_torque(None, name, value)
                    else:
                        robot.set_controls(None, {name: value})
                except InputError as err:
                    raise self.error(err.problem, f"{key}.{option}.{name}") from None
        for i in range(before, world.body_count):
            names[world.names[i]] = len(names)
        self.robots[robot.name] = robot
        # an MJCF model's <camera>s: the scene's cameras too ("ROBOT/CAMERA"), for tumble run --images
        for name, camera in robot.cameras.items():
            self.robot_cameras[f"{robot.name}/{name}"] = camera

    def _name_and_pose(self, entry: dict, key: str) -> dict:
        """The entry's ``name``, ``position`` and ``orientation`` or ``euler_deg``, as the loaders'
        keywords."""
        kw = {}
        if "name" in entry:
            kw["name"] = self.string(entry["name"], f"{key}.name")
            if not kw["name"]:
                raise self.error("must not be empty", f"{key}.name")
        for k in ("position", "euler_deg"):
            if k in entry:
                kw[k] = self.vector(entry[k], f"{key}.{k}")
        if "orientation" in entry:
            if "euler_deg" in entry:
                raise self.error("give orientation or euler_deg, not both", f"{key}.euler_deg")
            kw["orientation"] = self.vector(entry["orientation"], f"{key}.orientation", 4)
        return kw

    def _usd(self, world, entry: dict, key: str, names: dict):
        """A ``[[robots]]`` entry holding a USD stage: its bodies and joints added to the world."""
        for k in entry:
            if k not in ("file", "name", "position", "orientation", "euler_deg"):
                raise self.error("a robot option: a USD stage takes only file, name, position and orientation "
                                 "or euler_deg", f"{key}.{k}")
        path = Path(self.data_path(entry["file"], f"{key}.file", "USD"))
        kw = self._name_and_pose(entry, key)
        self.where = key
        before = world.body_count
        try:
            load_usd(world, path, **kw)
        except InputError as err:
            if err.file:  # the stage's own problem: both files on the line
                inner = ": ".join(str(p) for p in (Path(err.file).name, err.key) if p)
                raise self.error(f"{inner}: {err.problem}", f"{key}.file") from None
            raise err.within(key, self.file) from None
        for i in range(before, world.body_count):
            names[world.names[i]] = len(names)
