"""Checks of a run's state: ``state_hash``, ``check_state`` (blow-up), ``validate_world`` (invariants), limits.

Two tiers (STYLE 5.6 rules 4-6): ``check_state`` is cheap and runs on the
packed state ``Y`` (N, W) at the start of a run and after every frame (and, in
a diagnosis replay, after every stage); ``validate_world`` sweeps every
invariant of a ``World`` and runs after every stage when ``TUMBLE_VALIDATE=1``.
Both raise ``SimulationError`` with one line naming the body, the time, the
quantity and the stage. Memory limits for hostile input live here too.
"""

from __future__ import annotations

import hashlib
import math
import os
import re

import numpy as np

from .errors import InputError, SimulationError

# |q| - 1 beyond this (after the orientation is projected) is a blow-up. Unitless.
# Projection leaves |q| within a few 1e-16 of 1; 1e-9 leaves room for rounding
# in long runs and catches a state that was written without normalising.
QUATERNION_TOLERANCE = 1e-9
# Largest |R^T R - 1| entry allowed for the matrix layout (after projection). Unitless.
ORTHONORMALITY_TOLERANCE = 1e-9
# Relative tolerance of derived quantities (v = P/m, omega = I^-1 L, I^-1 = R Ibody^-1 R^T)
# in ``validate_world``. They are recomputed from the state, so any mismatch is a bug.
DERIVED_TOLERANCE = 1e-9
# Default of [simulation] max_energy_growth: see ``energy_bound``.
MAX_ENERGY_GROWTH = 1e6

QUANTITY_NAMES = {"x": "position x", "q": "orientation q", "R": "orientation R", "P": "linear momentum P", "L": "angular momentum L",
                  "F": "force F", "T": "torque tau"}


def validation_enabled() -> bool:
    """True when the environment variable ``TUMBLE_VALIDATE`` is set to 1 (or true/yes/on)."""
    return os.environ.get("TUMBLE_VALIDATE", "").strip().lower() in ("1", "true", "yes", "on")


# ---------------------------------------------------------------------- hashing


def state_hash(world) -> str:
    """SHA-256 (hex) of the world's state group: layout, body count, step time and x, q or R, P, L.

    Only state is hashed (STYLE 5.6 rule 2): two worlds with the same hash
    continue identically. The bytes are little-endian float64, so the hash is
    the same on any machine that computes the same bits.
    """
    h = hashlib.sha256()
    h.update(f"tumble-state/1 {world.layout} {world.body_count} ".encode())
    h.update(np.asarray([world.t], dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(world.pack(), dtype="<f8").tobytes())
    return h.hexdigest()


# ---------------------------------------------------------------------- blow-up checks


def _describe_row(values) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in np.asarray(values).ravel()) + "]"


def state_problem(Y: np.ndarray, layout: str, moving: np.ndarray, check_unit: bool = True):
    """The first problem in the packed state Y (N, W), or None.

    Returns ``(body index, quantity text)``: a non-finite x, q or R, P, L, or
    (with ``check_unit``) a quaternion off unit length / R off SO(3).
    """
    W = Y.shape[1]
    bad = ~np.isfinite(Y)
    if bad.any():
        i = int(np.flatnonzero(bad.any(axis=1))[0])
        col = int(np.flatnonzero(bad[i])[0])
        names = ["x"] * 3 + (["q"] * 4 if W == 13 else ["R"] * 9) + ["P"] * 3 + ["L"] * 3
        key = names[col]
        cols = [c for c, n in enumerate(names) if n == key]
        return i, f"non-finite {QUANTITY_NAMES[key]} = {_describe_row(Y[i, cols])}"
    if not check_unit or not len(Y):
        return None
    if layout == "quaternion":
        err = np.abs(np.sqrt(np.einsum("ij,ij->i", Y[:, 3:7], Y[:, 3:7])) - 1.0)
        err[~moving] = 0.0
        i = int(np.argmax(err))
        if err[i] > QUATERNION_TOLERANCE:
            return i, f"quaternion off unit length: |q| = {np.linalg.norm(Y[i, 3:7]):.12g} (tolerance {QUATERNION_TOLERANCE:g})"
    else:
        R = Y[:, 3:12].reshape(-1, 3, 3)
        err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        err[~moving] = 0.0
        i = int(np.argmax(err))
        if err[i] > ORTHONORMALITY_TOLERANCE:
            return i, f"rotation matrix off SO(3): max |R^T R - 1| = {err[i]:.3g} (tolerance {ORTHONORMALITY_TOLERANCE:g})"
    return None


def blow_up(names, body: int, quantity: str, t: float, stage: str, where: str = "") -> SimulationError:
    """The one-line ``SimulationError`` of a blow-up: body, time, quantity, stage."""
    text = f"body {names[body]!r}: {_headline(quantity)} at t = {t:.10g} s: {quantity} (stage {stage}{', ' + where if where else ''})"
    err = SimulationError(text)
    err.body, err.time, err.quantity, err.stage = names[body], t, quantity, stage
    return err


def _headline(quantity: str) -> str:
    if quantity.startswith("non-finite"):
        return "non-finite state"
    if quantity.startswith("energy"):
        return "energy growing past its bound"
    return "orientation off its manifold"


def check_state(world, stage: str = "check_state", where: str = "", Y: np.ndarray | None = None):
    """Raise ``SimulationError`` if the state (of ``world``, or the packed rows Y) is non-finite or off unit length."""
    Y = world.pack() if Y is None else Y
    problem = state_problem(Y, world.layout, world.moving)
    if problem is not None:
        raise blow_up(world.names, problem[0], problem[1], world.t, stage, where)


def energy_scale(world) -> float:
    """The energy a blow-up is measured against, J: KE + |PE|, but at least the kinetic
    energy of all moving mass at 1 m/s (so that a scene starting at rest has a scale)."""
    m = world.moving
    floor = 0.5 * float(np.sum(world.mass[m]))
    with np.errstate(over="ignore", invalid="ignore"):
        return max(world.kinetic_energy() + abs(world.potential_energy()), floor)


def energy_bound(e_ref: float, scale: float, growth: float) -> float:
    """Largest total energy allowed: E_ref + (growth - 1) * scale (J).

    ``growth`` is ``[simulation] max_energy_growth`` (default 1e6): a run whose
    total energy KE + PE (gravity, springs and joints' springs) rises above its start by more
    than (growth - 1) times ``energy_scale`` is stopped. Forces that do work
    outside PE (constant, point, wind, user forces) add energy legitimately;
    raise the factor for scenes driven hard by them. Impulses re-base the bound.
    """
    return e_ref + (growth - 1.0) * scale


def check_energy(world, e_ref: float, scale: float, growth: float, where: str = ""):
    """Raise ``SimulationError`` naming the body with the most kinetic energy if the total energy is past its bound."""
    with np.errstate(over="ignore", invalid="ignore"):
        e = world.kinetic_energy() + world.potential_energy()
    bound = energy_bound(e_ref, scale, growth)
    if e > bound or not math.isfinite(e):
        with np.errstate(over="ignore", invalid="ignore"):
            ke = 0.5 * (np.einsum("ij,ij->i", world.P, world.v) + np.einsum("ij,ij->i", world.L, world.omega))
        ke = np.where(world.moving & np.isfinite(ke), ke, -np.inf)
        i = int(np.argmax(ke))
        q = (f"energy E = {e:.6g} J above the bound {bound:.6g} J = E0 + (max_energy_growth - 1) x {scale:.6g} J "
             f"(E0 = {e_ref:.6g} J, max_energy_growth = {growth:g}); this body holds the most kinetic energy, {ke[i]:.6g} J")
        raise blow_up(world.names, i, q, world.t, "check_energy", where)


# ---------------------------------------------------------------------- invariants


def validate_world(world, stage: str = "validate_world", check_unit: bool = True):
    """Every invariant of a World: finite constants and state, unit q or orthonormal R,
    q and R describing the same rotation, and derived v, omega, I^-1 consistent with the state.

    Raises:
        SimulationError: one line naming the body, the quantity, the time and the stage.
    """
    n = world.body_count
    if n == 0:
        return
    names, t = world.names, world.t
    m = world.moving
    problem = state_problem(world.pack(), world.layout, m, check_unit)
    if problem is not None:
        raise blow_up(names, problem[0], problem[1], t, stage)
    for key in ("mass", "inv_mass", "inertia_body_inv", "com_offset"):
        rows = getattr(world, key)[m]
        arr = rows.reshape(len(rows), -1) if len(rows) else rows.reshape(0, 1)  # none moving: nothing to check
        bad = ~np.all(np.isfinite(arr), axis=1)
        if bad.any():
            i = int(np.flatnonzero(m)[np.flatnonzero(bad)[0]])
            raise blow_up(names, i, f"non-finite constant {key}", t, stage)
    if np.any(world.mass[m] <= 0):
        i = int(np.flatnonzero(m)[np.flatnonzero(world.mass[m] <= 0)[0]])
        raise blow_up(names, i, f"non-positive mass {world.mass[i]:g}", t, stage)
    R_of_q = _quat_to_matrix_rows(world.q)
    _close(world, np.abs(R_of_q - world.R).max(axis=(1, 2)), 1.0, "R and q describe different rotations", stage)
    with np.errstate(over="ignore", invalid="ignore"):
        v = world.P * world.inv_mass[:, None]
        I_inv = np.einsum("nij,njk,nlk->nil", world.R, world.inertia_body_inv, world.R)
        omega = np.einsum("nij,nj->ni", I_inv, world.L)
    v[~m] = 0.0
    omega[~m] = 0.0
    scale_v = np.maximum(np.abs(v).max(axis=1), 1.0)
    _close(world, np.abs(world.v - v).max(axis=1), scale_v, "velocity v != P / m", stage)
    scale_i = np.maximum(np.abs(I_inv).max(axis=(1, 2)), 1e-300)
    _close(world, np.abs(world.I_inv - I_inv).max(axis=(1, 2)) * m, scale_i, "I^-1 != R Ibody^-1 R^T", stage)
    scale_w = np.maximum(np.abs(omega).max(axis=1), 1.0)
    _close(world, np.abs(world.omega - omega).max(axis=1), scale_w, "angular velocity omega != I^-1 L", stage)


def _quat_to_matrix_rows(q):
    """(N, 3, 3) rotation matrices of the (normalised) quaternion rows q (N, 4)."""
    q = q / np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
    ], axis=1)


def _close(world, err, scale, what, stage):
    rel = err / scale
    rel[~world.moving] = 0.0
    bad = ~(rel <= DERIVED_TOLERANCE)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise blow_up(world.names, i, f"inconsistent derived quantity: {what} (relative error {rel[i]:.3g})", world.t, stage)


# ---------------------------------------------------------------------- memory limits

# Bytes of one recorded frame per body: position 3, orientation 4, velocity 3,
# angular velocity 3, P 3, L 3 float64 numbers.
FRAME_BYTES_PER_BODY = 19 * 8
# Rough bytes of working memory per body (World arrays, scratch, shape record, Python objects).
BODY_BYTES = 4096
# Rough bytes per particle / mesh vertex or face once parsed (Python lists, then arrays, then trimesh).
ITEM_BYTES = 256
# Reading a text file (TOML, JSON, OBJ...) into Python objects takes about this many times its size.
FILE_EXPANSION = 40


def memory_limit() -> int | None:
    """The memory a run may plan to use, bytes: ``TUMBLE_MAX_MEMORY`` ("16G", "512M",
    a number of bytes, or "none"), else half the physical memory (8 GiB if unknown)."""
    text = os.environ.get("TUMBLE_MAX_MEMORY", "").strip()
    if text:
        if text.lower() in ("none", "off", "0", "inf"):
            return None
        return parse_size(text, "TUMBLE_MAX_MEMORY")
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2)
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def parse_size(text: str, key: str) -> int:
    """Bytes from "123", "1.5G", "512M", "64k" (binary units)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)i?[bB]?\s*", str(text))
    if not m:
        raise InputError(f"expected a size such as 16G, 512M or a number of bytes, got {text!r}", key)
    return int(float(m.group(1)) * 1024 ** " kmgt".index(m.group(2).lower() or " "))


def fmt_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024.0
    return f"{n:.3g} TiB"


def check_memory(estimate: float, what: str, key: str | None = None, file: str | None = None, limit: int | None = -1):
    """InputError if ``estimate`` bytes exceed the limit (``memory_limit()`` unless given)."""
    limit = memory_limit() if limit == -1 else limit
    if limit is not None and estimate > limit:
        raise InputError(f"{what} would need about {fmt_bytes(estimate)}, above the memory limit of {fmt_bytes(limit)} "
                         f"(set TUMBLE_MAX_MEMORY, e.g. TUMBLE_MAX_MEMORY=64G, to allow it)", key, file)
