"""tumble: rigid-body dynamics after Baraff's SIGGRAPH 2001 notes, vectorised and compiled.

Quick start::

    import tumble as tb
    world = tb.World(gravity=(0, 0, -9.81))
    box = world.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, angular_velocity=(2, 1, 3))
    traj = tb.Simulator(world, dt=1/240, integrator="rk4").run(duration=10.0)
"""

__version__ = "0.1.0"

from .camera import Camera, CameraImage
from .collision.filter import CollisionFilter
from .decomposition import decompose
from .errors import InputError, SimulationError, TumbleError, TumbleWarning
from .forces import Buoyancy, ConstantForce, CustomForce, Drag, Explosion, Fluid, Impulse, PointForce, Spring, Switch, Wind
from .kinematic import KeyframePath
from .joints import BallJoint, DistanceJoint, FixedJoint, GearJoint, HingeJoint, SliderJoint, UniversalJoint
from .shapes import Box, Capsule, Compound, Cone, Convex, Cylinder, Ellipsoid, Mesh, Particles, Plane, Sphere, heightfield
from .simulator import Simulator
from .snapshot import SimState
from .trajectory import Trajectory, load_trajectory
from .world import Body, Material, World


def fracture(shape, pieces: int = 16, seed: int = 0, points=None):
    """Cut a convex shape into the Voronoi cells of ``pieces`` random points (``World.add_fractured``
    glues them into a breakable body). See tumble.fracturing."""
    from .fracturing import fracture as _fracture

    return _fracture(shape, pieces, seed, points)


def load_scene(path):
    """Read a scene file (TOML or JSON) into a ``Scene`` (its World and settings). See tumble.scene."""
    from .scene import load_scene as _load

    return _load(path)


def load_urdf(world, path, **options):
    """Add a URDF file's robot to ``world``: its links as bodies, its joints as joints; returns a
    ``tumble.urdf.Robot``. Options (pose, fixed_base, joint_positions, ...): see tumble.urdf."""
    from .urdf import load_urdf as _load

    return _load(world, path, **options)


def load_mjcf(world, path, **options):
    """Add a MuJoCo model file (MJCF XML) to ``world``: its bodies as bodies, its joints as joints;
    returns a ``tumble.urdf.Robot``. Options (pose, joint_positions, ...): see tumble.mjcf."""
    from .mjcf import load_mjcf as _load

    return _load(world, path, **options)


def load_usd(world, path, **options):
    """Add a USD stage's rigid bodies, colliders and joints (the UsdPhysics schema: Omniverse, Isaac
    Sim, PhysX) to ``world``; returns a ``tumble.usd_physics.UsdScene``. See tumble.usd_physics."""
    from .usd_physics import load_usd as _load

    return _load(world, path, **options)


def save_usd(world, path):
    """Write ``world`` (its bodies at their current state, its joints) as a USD stage with physics
    (the UsdPhysics schema), which ``load_usd``, Omniverse and Isaac Sim read. See
    tumble.export.usd_scene."""
    from .export.usd_scene import save_usd as _save

    return _save(world, path)


__all__ = [
    "World", "Body", "Material", "CollisionFilter", "Simulator", "SimState", "Trajectory", "load_trajectory", "load_scene",
    "load_urdf", "load_mjcf", "load_usd", "save_usd", "Camera", "CameraImage",
    "Sphere", "Box", "Capsule", "Cylinder", "Cone", "Ellipsoid", "Plane", "Particles", "Mesh", "Convex", "Compound", "heightfield", "decompose", "fracture",
    "Drag", "Wind", "ConstantForce", "PointForce", "Spring", "Switch", "Impulse", "Explosion", "Blast", "Buoyancy", "Fluid", "CustomForce",
    "BallJoint", "HingeJoint", "SliderJoint", "FixedJoint", "DistanceJoint", "UniversalJoint", "GearJoint",
    "KeyframePath",
    "TumbleError", "InputError", "SimulationError", "TumbleWarning",
]


def __getattr__(name):
    # ``tb.Blast`` (what ``World.explode`` returns) is imported on first use: its module brings
    # the closest-point routines, which ``import tumble`` does not otherwise need
    if name == "Blast":
        from .collision.explosion import Blast

        return Blast
    raise AttributeError(f"module 'tumble' has no attribute {name!r}")
