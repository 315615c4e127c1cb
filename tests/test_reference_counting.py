"""The routines compiled without Numba's reference counting (``math3d.NO_NRT``: the convex
narrowphase, the joint solver, the ray casts) leave no array referenced.

A reference counted up in one routine and never down (an array handed back from a counted
routine to an uncounted one) would keep the array alive after its owners are gone; one counted
down too often would free it under its owner (a crash or garbage, which the physics tests
would see). Here every array the step and the cast read is watched by a weak reference, the
world and the simulator are dropped, and each array must be freed (checked to fail: a joint
helper that took a body's row of x through a counted call kept the state alive). The narrowphase kernel has
its own such test beside its pair-by-pair check (tests/collision/test_narrowphase_kernel.py).
"""

import gc
import sys
import weakref

import numpy as np

import tumble as tb


def _jointed_world():
    """A chain of three hinged boxes with limits and armature (the exact tree solve, its limit
    sweeps and armature rows), a convex hull and a cylinder falling onto a plane (the convex
    narrowphase), a sphere on the side (the ray casts)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    prev = "world"
    for k in range(3):
        link = w.add_body(tb.Box(size=(0.4, 0.1, 0.1)), mass=1.0, position=(0.2 + 0.4 * k, 0.0, 2.0))
        w.add_joint(tb.HingeJoint(prev, link, anchor=(0.4 * k, 0.0, 2.0), axis=(0.0, 1.0, 0.0), lower=-0.5,
                                  upper=0.5, armature=0.01))
        prev = link
    w.add_body(tb.Convex(points=np.random.default_rng(0).normal(size=(20, 3)) * 0.2), mass=1.0,
               position=(3.0, 0.0, 0.25))
    w.add_body(tb.Cylinder(0.2, 0.4), mass=1.0, position=(3.0, 0.05, 0.8), euler_deg=(30, 10, 0))
    w.add_body(tb.Sphere(0.3), mass=1.0, position=(-2.0, 0.0, 0.3))
    return w


def _arrays_of(obj, depth=3, seen=None):
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return []
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return [obj]
    if depth == 0:
        return []
    if isinstance(obj, dict):
        items = obj.values()
    elif isinstance(obj, (list, tuple)):
        items = obj
    elif hasattr(obj, "__dict__") and type(obj).__module__.startswith("tumble"):
        items = vars(obj).values()
    else:
        return []
    return [a for item in items for a in _arrays_of(item, depth - 1, seen)]


def test_step_and_ray_cast_leave_no_array_referenced():
    w = _jointed_world()
    sim = tb.Simulator(w, dt=1 / 240)
    sim.step(60)
    hits = w.ray_cast(origin=np.array([[-2.0, 0.0, 3.0], [3.0, 0.0, 3.0]]), direction=(0, 0, -1))
    assert hits.body[0] == 6 and hits.body[1] in (4, 5)  # the sphere; the hull or the cylinder on it
    assert sim.joint_settings is not None and sim.joint_settings.method == "tree"
    # every array the world and the simulator hold, two objects deep (the state, the step's
    # buffers, the joint and contact solvers' tables: what the kernels read and write)
    arrays = _arrays_of(w) + _arrays_of(sim)
    assert len(arrays) >= 50
    # the arrays the kernels get are often views (x of the packed state): watch each one's root
    roots = {}
    for a in arrays:
        while isinstance(a.base, np.ndarray):
            a = a.base
        roots[id(a)] = a
    # module constants (NO_FILTER, empty pair lists) live on by design
    constants = {id(v) for m in list(sys.modules.values()) if m is not None and m.__name__.startswith("tumble")
                 for v in vars(m).values() if isinstance(v, np.ndarray)}
    watched = [weakref.ref(a) for k, a in roots.items() if k not in constants]
    del roots, a
    del w, sim, hits, arrays
    gc.collect()
    assert [r() is None for r in watched] == [True] * len(watched)
