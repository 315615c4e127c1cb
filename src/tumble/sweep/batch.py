"""In-process batching: many independent variants of a small scene stepped as one World.

Variants are *batchable together* when their scenes share everything the
simulator applies to the world as a whole (``batch_key``): dt, integrator,
substeps, layout, duration, frame rate, gravity, the energy bound, the body
names and which bodies are fixed, and the steps at which impulses act; and no
force couples two bodies or calls Python (no springs, no custom forces), no explosion (its blast
would reach every variant's bodies at once), and the
integrator is not adaptive, and the scene has no contact (collisions off, or no two shapes
that can collide: variants merged into one World must not touch each other, and the
merged World has collisions off) and no kinematic bodies. Joints batch when each variant's
joint sweep is one sweep in its own order (fewer joints than ``partition_min_joints``; the
merged World sweeps with ``partitions = 1``: each variant's joints in their order, its bodies
touched by nobody else's) and, with the tree method, no joint has a limit and no joint is a
gear (its extra sweeps stop on a test over every joint: that would couple the variants); a world
whose joints default to the tree method (``world.exact_joints``) batches only with the scene's own
``[joint_solver]``; a URDF robot in free space batches. Their bodies may differ in anything else (shape,
mass, inertia, state, material) and so may their per-body forces (drag, wind, fluid,
constant, point forces, impulses).

``merge_worlds`` copies the variants' already-built worlds (each from
``scene.parse_scene``, so each variant is validated exactly as a single run)
row by row into one World, and their force records with body references moved
to the new rows (a drag "on every moving body" becomes a drag on that
variant's moving bodies). One ``Simulator.run`` steps them all: without
coupling forces the engine steps every body on its own (``integrators.
step_bodies_kernel``: the same operations in the same order for a body whatever
else is in the World), so each variant's frames are the bits of its single run.
``tests/test_sweep.py`` checks that.

The whole-world checks of a run (non-finite state, energy bound) see all the
variants at once, so a batch that fails is split in halves and each half run
again, down to single runs that report their own error; after a batch that
succeeds, a variant whose own energy came near its own bound is run again on
its own, so that its status is exactly that of a single run.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .. import checks
from .. import integrators as K
from ..errors import InputError, SimulationError
from ..forces import Buoyancy, ConstantForce, CustomForce, Drag, Explosion, Fluid, Impulse, PointForce, Spring, Switch
from ..joints import G_FOLLOWS, G_JOINT, JOINT_GEAR
from ..simulator import Simulator
from ..trajectory import Trajectory
from ..world import World
from . import metrics as M


def batch_key(scene):
    """A hashable key: scenes with equal keys can run in one World; None when the scene cannot be batched."""
    w = scene.world
    if K.INTEGRATOR_IDS[scene.integrator] in K.ADAPTIVE:
        return None
    # an explosion reaches every variant; buoyancy's rows are filled step by step for the world's bodies;
    # a switch changes the merged world's stages mid-run (World.set_enabled)
    if any(isinstance(f, (Spring, CustomForce, Explosion, Buoyancy, Switch)) for f in w.forces):
        return None
    if w.collisions and _can_collide(w):
        return None
    joint_key = _joint_key(scene)
    if joint_key is None:
        return None
    if w.kinematic.any():  # kinematic bodies are stepped one step at a time, paths by body row
        return None
    if w.exact_joints and scene.joint_settings is None:  # armature, gears, MJCF: its own Simulator picks the tree
        return None
    impulse_steps = tuple(sorted({int(np.ceil(f.time / scene.dt - 1e-9)) for f in w.forces if isinstance(f, Impulse)}))
    return (
        scene.integrator, scene.layout, float(scene.dt), int(scene.substeps), float(scene.duration), float(scene.frame_rate),
        tuple(float(g) for g in w.gravity), float(scene.max_energy_growth), tuple(w.names), tuple(bool(m) for m in w.moving),
        impulse_steps, bool(w.sleeping), joint_key,
    )


def _joint_key(scene):
    """() without joints; the joint settings as a tuple when the joints can be batched (module
    docstring); None when they cannot."""
    from ..joints import P_LIMIT2_ON, P_LIMIT_ON
    from ..solver.joints import JointSettings

    joints = getattr(scene.world, "joints", None) or []
    if not joints:
        return ()
    st = scene.joint_settings or JointSettings()
    if (st.partitions > 1 and len(joints) >= st.partition_min_joints) or any(j.broken for j in joints):
        return None
    # the tree's sweeps while a limit's or a gear's impulse changes run over all joints: one variant's
    # convergence would set another's sweep count (then its bits)
    if st.method == "tree" and any(j.bound.param[P_LIMIT_ON] or j.bound.param[P_LIMIT2_ON]
                                   or j.bound.type_id == JOINT_GEAR for j in joints):
        return None
    return dataclasses.astuple(st)


# worlds up to this many bodies are checked pair by pair for a pair that may touch (a robot whose
# links never touch each other batches); larger ones by the soft step's coarser test
PAIR_CHECK_BODIES = 64


def _can_collide(world: World) -> bool:
    """True when two shapes of the world can touch (contact would act in a single run)."""
    from ..solver.soft_step import SoftStep

    if not SoftStep(world).has_collisions():
        return False
    n = world.body_count
    if n > PAIR_CHECK_BODIES:
        return True
    return any((world.moving[a] or world.moving[b]) and world.should_collide(a, b)
               for a in range(n) for b in range(a + 1, n))


def merge_worlds(worlds: list[World]) -> World:
    """One World holding the bodies of ``worlds`` (same gravity and layout) one after another.

    Body ``j`` of ``worlds[k]`` becomes row ``sum(n of worlds before k) + j``, named
    ``"{k}/{name}"``; every array row is copied bit for bit. Force records are
    copied with their body references turned into row indices. Uses the World's
    storage (``_arrays``) directly: a World has no public "append rows" call.
    """
    w0 = worlds[0]
    merged = World(gravity=w0.gravity, layout=w0.layout)
    merged.collisions = False  # the variants share space but never touch (batch_key)
    merged.sleeping = w0.sleeping
    total = sum(w.body_count for w in worlds)
    merged._allocate(max(total, 1))
    for name, arr in merged._arrays.items():
        np.concatenate([w._arrays[name][: w.body_count] for w in worlds], out=arr[:total])
    merged.body_count = total
    offset = 0
    for k, w in enumerate(worlds):
        for j, name in enumerate(w.names):
            merged.names.append(f"{k}/{name}")
            merged._index_by_name[f"{k}/{name}"] = offset + j
        merged.shapes.extend(w.shapes)
        merged.materials.extend(w.materials)
        merged.collision_filters.extend(w.collision_filters)
        merged.excluded_collisions.update((offset + a, offset + b) for a, b in w.excluded_collisions)
        merged.pair_materials.update({(offset + a, offset + b): m for (a, b), m in w.pair_materials.items()})
        for rec in w.forces:
            merged.add_force(_moved(rec, w, offset))
        first_joint = len(merged.joints)
        for rec in getattr(w, "joints", ()):
            merged.joints.append(_moved_joint(rec, k, offset, first_joint))
        offset += w.body_count
    merged._tables = None
    return merged


def _moved(rec, w: World, offset: int):
    row = lambda b: offset + w.index_of(b)
    if isinstance(rec, (Drag, Fluid)):  # a fluid's frames stay with their bodies (the same order)
        bodies = np.flatnonzero(w.moving) if rec.bodies is None else [w.index_of(b) for b in rec.bodies]
        return dataclasses.replace(rec, bodies=[offset + int(i) for i in bodies])
    if isinstance(rec, (ConstantForce, PointForce, Impulse)):
        return dataclasses.replace(rec, body=row(rec.body))
    raise InputError(f"cannot batch a force record {type(rec).__name__}", "forces")


def _moved_joint(rec, k: int, offset: int, first_joint: int):
    """A copy of a bound joint record with its bodies at the merged rows (the bound frames, anchors
    and parameters copied as they are: binding again would read the poses, which a URDF's start
    joint positions moved after binding); a gear's two joints at the merged joint rows (the
    variant's joints start at ``first_joint``)."""
    b = rec.bound
    row = lambda i: -1 if i < 0 else offset + i
    new = dataclasses.replace(rec, body_a=row(b.body_a), body_b=row(b.body_b),
                              name=None if rec.name is None else f"{k}/{rec.name}")
    new.bound = dataclasses.replace(b, body_a=row(b.body_a), body_b=row(b.body_b), local_a=np.copy(b.local_a),
                                    local_b=np.copy(b.local_b), frame_a=np.copy(b.frame_a), frame_b=np.copy(b.frame_b),
                                    param=np.copy(b.param))
    if b.type_id == JOINT_GEAR:
        for column in (G_JOINT, G_FOLLOWS):
            if new.bound.param[column] >= 0:  # (-1: a lock follows no joint)
                new.bound.param[column] += first_joint
        # fields fixed once bound (tumble.joints.edit_joint refuses them): set as the binding would
        object.__setattr__(new, "joint", int(new.bound.param[G_JOINT]))
        object.__setattr__(new, "follows", None if new.bound.param[G_FOLLOWS] < 0 else int(new.bound.param[G_FOLLOWS]))
    object.__setattr__(new, "broken", rec.broken)
    return new


class _VariantState:
    """What ``checks.state_hash`` reads of a World, for one variant's rows of a batch."""

    def __init__(self, layout: str, t: float, Y: np.ndarray):
        self.layout = layout
        self.t = t
        self.body_count = len(Y)
        self._Y = np.ascontiguousarray(Y)

    def pack(self):
        return self._Y


def body_info(world: World) -> M.BodyInfo:
    springs = []
    for f in world.forces:
        if isinstance(f, Spring):
            b = -1 if f.body_b is None else world.index_of(f.body_b)
            springs.append((world.index_of(f.body_a), b, tuple(f.anchor_a), tuple(f.anchor_b), f.stiffness, f.rest_length))
    sensors = tuple(world.names[i] for i in np.flatnonzero(world.sensor))
    return M.BodyInfo(tuple(world.names), tuple(bool(m) for m in world.moving), tuple(springs), sensors)


@dataclasses.dataclass
class Outcome:
    """One variant's result: metric columns (floats), state hash, trajectory (if kept), wall time, batch size."""

    values: dict
    state_hash: str
    trajectory: Trajectory | None
    wall_time_s: float
    batch_size: int


def run_single(scene, metrics: list[M.Metric], keep_trajectory: bool = False) -> Outcome:
    """Run one scene as ``Scene.run`` does; SimulationError propagates."""
    started = time.perf_counter()
    traj = scene.simulator().run(scene.duration, scene.frame_rate, progress=False)
    w = scene.world
    fr = M.Frames.from_trajectory(traj, 1)
    vals = M.compute(metrics, fr, w.mass[None, :], w.gravity, body_info(w), w.gravity_scale[None, :])
    out = {c: float(v[0]) for c, v in vals.items()}
    return Outcome(out, checks.state_hash(w), traj if keep_trajectory else None, time.perf_counter() - started, 1)


def run_group(scenes: list, metrics: list[M.Metric], keep_trajectory: bool = False) -> list[Outcome | None]:
    """Run scenes of one ``batch_key`` as one World. Returns an Outcome per scene, or None for a
    scene to be run again alone (its energy came near its bound). Raises what the run raises."""
    started = time.perf_counter()
    s0 = scenes[0]
    V = len(scenes)
    n = s0.world.body_count
    merged = merge_worlds([s.world for s in scenes])
    joint_settings = None
    if merged.joints:  # each variant's joints in their own order (batch_key): one sweep, not slabs
        from ..solver.joints import JointSettings

        joint_settings = dataclasses.replace(s0.joint_settings or JointSettings(), partitions=1)
    sim = Simulator(merged, dt=s0.dt, integrator=s0.integrator, substeps=s0.substeps, rtol=s0.rtol, atol=s0.atol,
                    max_energy_growth=s0.max_energy_growth, joint_settings=joint_settings)
    traj = sim.run(s0.duration, s0.frame_rate, progress=False)
    fr = M.Frames.from_trajectory(traj, V)
    mass = np.stack([s.world.mass for s in scenes])
    gravity_scale = np.stack([s.world.gravity_scale for s in scenes])  # (V, n): World.set_gravity_scale
    info = body_info(s0.world)
    E = M.energies(fr, mass, merged.gravity, info, gravity_scale)
    with np.errstate(all="ignore"):
        floor = 0.5 * np.sum(np.where(np.array(info.moving)[None, :], mass, 0.0), axis=1)
        scale = np.maximum(np.abs(E[0]), floor)
        bound = E.min(axis=0) + 0.5 * (s0.max_energy_growth - 1.0) * scale
        suspect = ~np.all(np.isfinite(E), axis=0) | np.any(E > bound[None, :], axis=0)
    vals = M.compute(metrics, fr, mass, merged.gravity, info, gravity_scale)
    Y = merged.pack()
    each = (time.perf_counter() - started) / V
    out: list[Outcome | None] = []
    for k in range(V):
        if suspect[k]:
            out.append(None)
            continue
        rows = slice(k * n, (k + 1) * n)
        h = checks.state_hash(_VariantState(merged.layout, merged.t, Y[rows]))
        t_k = split_trajectory(traj, rows, s0.world, mass[k], gravity_scale[k]) if keep_trajectory else None
        out.append(Outcome({c: float(v[k]) for c, v in vals.items()}, h, t_k, each, V))
    return out


def run_batched(scenes: list, metrics: list[M.Metric], keep_trajectory: bool = False) -> list[Outcome | Exception]:
    """Outcomes of scenes of one batch key: batched, halved on failure, single runs where needed.
    A variant that fails alone gets its exception (SimulationError or InputError) instead."""
    if len(scenes) == 1:
        try:
            return [run_single(scenes[0], metrics, keep_trajectory)]
        except (SimulationError, InputError) as err:
            return [err]
    try:
        got = run_group(scenes, metrics, keep_trajectory)
    except (SimulationError, InputError):
        mid = len(scenes) // 2
        return run_batched(scenes[:mid], metrics, keep_trajectory) + run_batched(scenes[mid:], metrics, keep_trajectory)
    return [g if g is not None else run_batched([s], metrics, keep_trajectory)[0] for g, s in zip(got, scenes)]


def split_trajectory(traj: Trajectory, rows: slice, world: World, mass: np.ndarray, gravity_scale=None) -> Trajectory:
    """One variant's Trajectory from a batch's: its bodies' frames (bit for bit) and its own totals
    (recomputed here over its bodies; a single run sums them in the engine, so totals may differ in the last bits)."""
    per = {k: np.ascontiguousarray(getattr(traj, k)[:, rows]) for k in
           ("position", "orientation", "velocity", "angular_velocity", "linear_momentum", "angular_momentum")}
    m = world.moving
    with np.errstate(all="ignore"):
        P, v, L, w = per["linear_momentum"][:, m], per["velocity"][:, m], per["angular_momentum"][:, m], per["angular_velocity"][:, m]
        ke = 0.5 * np.sum(P * v, axis=(1, 2)) + 0.5 * np.sum(L * w, axis=(1, 2))
        weight = mass[m] if gravity_scale is None else gravity_scale[m] * mass[m]  # s m (World.set_gravity_scale)
        pe = -np.sum(weight[None, :] * (per["position"][:, m] @ world.gravity), axis=1)
        x = per["position"][:, m]
        q = per["orientation"][:, m]
    orth = np.max(np.abs(np.sum(q * q, axis=2) - 1.0), axis=1) if q.shape[1] else np.zeros(len(traj.time))
    return Trajectory(
        time=traj.time.copy(), names=np.array(world.names, dtype=str), **per,
        kinetic_energy=ke, potential_energy=pe, total_linear_momentum=P.sum(axis=1),
        total_angular_momentum=(L + np.cross(x, P)).sum(axis=1), orthonormality_error=orth,
        com_offset=None if traj.com_offset is None else np.ascontiguousarray(traj.com_offset[rows]),
        shape_table=traj.shape_table, shape_index=None if traj.shape_index is None else traj.shape_index[rows].copy(),
        fixed=None if traj.fixed is None else traj.fixed[rows].copy(),
        sensor=None if traj.sensor is None else traj.sensor[rows].copy(),
    )
