"""Checkpoint files: a World and its Simulator, saved so that a continuation is bit-identical.

A checkpoint is an .npz (loaded with ``allow_pickle=False``) holding:

* ``meta``: JSON text: format and version, the time and step index, the world's
  layout and gravity, per body its name, shape (``shapes.shape_to_dict``) and
  material, the force records (bodies by name; ``CustomForce`` as a placeholder),
  the impulses already applied, the simulator's settings, statistics and energy
  reference, and the caller's ``run`` data (``run_to_file`` keeps its progress there);
* the constant arrays (mass, inertia, principal axes, centre-of-mass offsets) and
  the state arrays ``x q R P L`` exactly as they are in memory: the rebuilt World
  takes these bits, not values recomputed from the shapes.

Loading rebuilds the World body by body, overwrites its arrays with the saved
ones, then runs ``checks.validate_world``; any problem is an ``InputError``.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields
from pathlib import Path

import numpy as np

from . import __version__, checks
from .errors import InputError, SimulationError
from .forces import ConstantForce, CustomForce, Drag, Impulse, PointForce, Spring
from .solver.contact import SoftStepSettings
from .shapes import shape_from_dict, shape_to_dict
from .trajectory import write_atomic
from .world import Material, World

FORMAT = "tumble-checkpoint"
VERSION = 1
CONSTANTS = ("mass", "inv_mass", "inertia_body", "inertia_body_inv", "principal_q", "principal_moments", "com_offset", "moving")
STATE = ("x", "q", "R", "P", "L")
FORCE_CLASSES = {c.__name__: c for c in (Drag, ConstantForce, PointForce, Spring, Impulse, CustomForce)}
BODY_FIELDS = ("body", "body_a", "body_b")


def _force_to_dict(world: World, force) -> dict:
    out = {"type": type(force).__name__}
    for f in fields(force):
        value = getattr(force, f.name)
        if f.name == "function":
            continue
        if f.name in BODY_FIELDS:
            value = None if value is None else world.names[world.index_of(value)]
        elif f.name == "bodies":
            value = None if value is None else [world.names[world.index_of(b)] for b in value]
        elif isinstance(value, tuple):
            value = list(value)
        out[f.name] = value
    return out


def save_checkpoint(sim, path, run: dict | None = None) -> Path:
    """``Simulator.save_checkpoint``: write ``sim`` and its world to ``path`` atomically."""
    w = sim.world
    if getattr(w, "joints", None):
        raise InputError("checkpoints of worlds with joints are not supported yet", "joints")
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "tumble_version": __version__,
        "t": w.t,
        "step_index": sim.step_index,
        "layout": w.layout,
        "gravity": [float(g) for g in w.gravity],
        "names": list(w.names),
        "shapes": [shape_to_dict(s) for s in w.shapes],
        "materials": [{"friction": m.friction, "restitution": m.restitution} for m in w.materials],
        "forces": [_force_to_dict(w, f) for f in w.forces],
        "applied_impulses": sorted(int(k) for k in w.applied_impulses),
        "settings": sim.settings(),
        "stats": {k: v for k, v in sim.stats.items()},
        "energy_reference": sim.energy_reference,
        "collisions": bool(getattr(w, "collisions", True)),
        "sleeping": bool(getattr(w, "sleeping", True)),
        "run": run,
    }
    arrays = {name: np.ascontiguousarray(getattr(w, name)) for name in CONSTANTS + STATE}
    # the contact solver's warm-start impulses: without them a resumed run differs in the last bits
    if sim.soft_step is not None:
        for name, arr in sim.soft_step.solver.warm_start_state().items():
            arrays["contact_" + name] = np.ascontiguousarray(arr)
    if sim.sleep is not None:  # the sleep timers and flags: a resumed run sleeps when the whole one does
        for name, arr in sim.sleep.state().items():
            arrays["sleep_" + name] = np.ascontiguousarray(arr)
    arrays["meta"] = np.array(json.dumps(meta, default=_json_default, allow_nan=True))
    return write_atomic(path, lambda fh: np.savez(fh, **arrays))


def _json_default(o):
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def load_checkpoint(cls, path, custom_forces=None):
    """``Simulator.load_checkpoint``: rebuild the World and a Simulator of class ``cls``."""
    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise InputError("checkpoint file not found", None, file)
    try:
        # our own handle: np.load leaks its own when the zip is damaged
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {name: np.array(data[name]) for name in CONSTANTS + STATE}
            warm = {name[len("contact_"):]: np.array(data[name]) for name in WARM_START if name in data.files}
            sleep = {name[len("sleep_"):]: np.array(data[name]) for name in data.files if name.startswith("sleep_")}
    except Exception as exc:  # damaged or foreign file: one line
        raise InputError(f"not a readable checkpoint file ({type(exc).__name__}: {' '.join(str(exc).split())})", None, file) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError("not a tumble checkpoint file", None, file)
    if meta.get("version") != VERSION:
        raise InputError(f"checkpoint format version {meta.get('version')!r} is not supported (expected {VERSION})", None, file)
    try:
        sim = _rebuild(cls, meta, arrays, custom_forces)
        if len(warm) == len(WARM_START):
            _restore_warm_start(sim, warm)
        if sleep:
            from .solver.island import SleepState

            sim.sleep = SleepState(sim.world.body_count)
            sim.sleep.set_state(sleep)
    except InputError as err:
        raise InputError(f"checkpoint does not rebuild: {err}", None, file) from None
    except SimulationError as err:
        raise InputError(f"checkpoint state is invalid: {err}", None, file) from None
    except Exception as exc:
        raise InputError(f"checkpoint does not rebuild ({type(exc).__name__}: {' '.join(str(exc).split())})", None, file) from None
    return sim


WARM_START = ("contact_key", "contact_normal_impulse", "contact_friction_impulse")


def _restore_warm_start(sim, warm: dict):
    k = len(warm["key"])
    if warm["key"].dtype.kind != "i" or warm["normal_impulse"].shape != (k,) or warm["friction_impulse"].shape != (k, 3):
        raise InputError("contact warm-start arrays have inconsistent shapes")
    if sim._contact_on():
        sim.soft_step.solver.set_warm_start_state(warm)


def _rebuild(cls, meta: dict, arrays: dict, custom_forces):
    names = meta["names"]
    n = len(names)
    for name, arr in arrays.items():
        expected = {"moving": (n,), "mass": (n,), "inv_mass": (n,)}.get(name)
        if arr.shape[:1] != (n,) or (expected is not None and arr.shape != expected):
            raise InputError(f"array {name!r} has shape {arr.shape}, expected {n} rows")
        if arr.dtype.kind not in "fb":
            raise InputError(f"array {name!r} has dtype {arr.dtype}, expected numbers")
    w = World(gravity=meta["gravity"], layout=meta["layout"])
    moving = arrays["moving"].astype(bool)
    for i, name in enumerate(names):
        shape = shape_from_dict(meta["shapes"][i])
        kw = {}
        if moving[i] and type(shape).__name__ != "Particles":
            kw["mass"] = float(arrays["mass"][i])
        w.add_body(shape, name=name, fixed=not moving[i], material=Material(**meta["materials"][i]), **kw)
    for name in CONSTANTS + STATE:
        getattr(w, name)[:] = arrays[name]
    customs = list(custom_forces or [])
    wanted = sum(1 for f in meta["forces"] if f["type"] == "CustomForce")
    if len(customs) != wanted:
        raise InputError(f"the world has {wanted} CustomForce record(s): give their functions as custom_forces (got {len(customs)})")
    for record in meta["forces"]:
        record = dict(record)
        kind = FORCE_CLASSES.get(record.pop("type"))
        if kind is None:
            raise InputError("unknown force type in checkpoint")
        if kind is CustomForce:
            record["function"] = customs.pop(0)
        w.add_force(kind(**record))
    w.t = float(meta["t"])
    w.collisions = bool(meta.get("collisions", True))
    w.sleeping = bool(meta.get("sleeping", True))
    w.applied_impulses = {int(k) for k in meta["applied_impulses"]}
    w.update_derived()
    checks.validate_world(w, "load_checkpoint")
    s = meta["settings"]
    sim = cls(w, dt=s["dt"], integrator=s["integrator"], substeps=s["substeps"], rtol=s["rtol"], atol=s["atol"],
              max_energy_growth=s["max_energy_growth"],
              contact_settings=SoftStepSettings(**s["contact"]) if "contact" in s else None,
              record_contacts=bool(s.get("record_contacts", False)))
    sim.step_index = int(meta["step_index"])
    if not math.isclose(sim.step_index * sim.dt, w.t, rel_tol=1e-12, abs_tol=1e-12):
        raise InputError(f"step index {sim.step_index} does not match t = {w.t}")
    sim.stats.update(meta["stats"])
    sim.energy_reference = meta["energy_reference"]
    sim.checkpoint_run = meta["run"]
    return sim
