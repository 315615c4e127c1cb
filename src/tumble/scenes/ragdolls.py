"""Named scene: n ragdolls dropped from a grid onto a ground plane, falling into a pile (issue 4's
joint benchmark, ``benchmarks/ragdolls.py``).

The ragdoll is the one of ``examples/joints/ragdoll_stairs.toml`` (11 bodies: pelvis, torso,
head, upper and lower arms and legs; ball joints with cone and twist limits at the waist, neck,
shoulders and hips, hinges with angle limits at the elbows and knees). Its moving bodies and
their joints are read from the TOML file with ``tomllib`` (the fixed bodies, the ground and
the stairs, are left out, as are the bodies' launch velocities: the ragdolls are dropped from
rest) and copied n times, each copy turned by a seeded random yaw about the vertical through
its pelvis and moved to its grid cell, with every body and joint name suffixed ``_<copy>``.
The copies are built by ``tumble.scene.parse_scene``, so they mean exactly what the example
file means.

Layout: a k x k grid (k = ceil(sqrt n)) with ``spacing`` m between cells, centred on x = y = 0,
filled x fastest; each ragdoll's lowest point at a seeded random height in ``heights`` m
(default 1 to 3 m). A ragdoll is 0.59 m across, so neighbours 1 m apart do not touch at the
start. At 1 m they mostly collapse side by side (in tumble and MuJoCo no pelvis ends above
0.3 m); ``spacing=0.65`` drops them closer, and some then end on top of others.

``ragdolls(n, seed)`` returns ``(world, settings)`` as the contact scenes do
(``tumble.scenes.contact``): settings ``{"dt": 1/60, "substeps": 4, "duration": 5, "steps": 300}``.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np

from ..shapes import Box, Capsule, Cylinder, Sphere

#: the example this scene copies (the repository's examples/joints/ragdoll_stairs.toml)
RAGDOLL_TOML = Path(__file__).resolve().parents[3] / "examples" / "joints" / "ragdoll_stairs.toml"
DT = 1.0 / 60.0
SUBSTEPS = 4
DURATION = 5.0
BODIES_PER_RAGDOLL = 11
JOINTS_PER_RAGDOLL = 10


def grid_side(n: int) -> int:
    """k = ceil(sqrt(n)) in integers."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    k = math.isqrt(n)
    return k if k * k >= n else k + 1


def _quat_mul(p, q):
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return [pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw]


def lowest_point_z(shapes, x: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n,) z (m) of the lowest point of each shape at centres x (n, 3) and rotations R (n, 3, 3)
    (sphere, capsule, box, cylinder; +inf for planes and other shapes)."""
    out = np.full(len(shapes), math.inf)
    for i, s in enumerate(shapes):
        Rz = R[i][2]  # world z of each body axis
        if isinstance(s, Sphere):
            out[i] = x[i, 2] - s.radius
        elif isinstance(s, Capsule):
            out[i] = x[i, 2] - 0.5 * s.length * abs(Rz[2]) - s.radius
        elif isinstance(s, Box):
            out[i] = x[i, 2] - float(np.abs(Rz) @ s.half_extents)
        elif isinstance(s, Cylinder):
            out[i] = x[i, 2] - 0.5 * s.length * abs(Rz[2]) - s.radius * math.sqrt(max(0.0, 1.0 - Rz[2] ** 2))
    return out


def read_ragdoll(path=None) -> tuple[dict, list[dict], list[dict]]:
    """(simulation table, moving bodies, their joints) of the ragdoll example file."""
    with open(path or RAGDOLL_TOML, "rb") as fh:
        doc = tomllib.load(fh)
    bodies = [b for b in doc["bodies"] if not b.get("fixed", False)]
    names = {b["name"] for b in bodies}
    joints = [j for j in doc.get("joints", []) if j["body_a"] in names and j.get("body_b", "world") in names]
    return doc.get("simulation", {}), bodies, joints


def ragdolls(n: int = 100, seed: int = 0, spacing: float = 1.0, heights=(1.0, 3.0), path=None,
             friction: float = 0.5):
    """n ragdolls over a k x k grid, dropped from rest onto the plane z = 0 (friction ``friction``,
    restitution 0, as the example's default material). Returns ``(world, settings)``."""
    from ..scene import parse_scene

    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    sim, bodies, joints = read_ragdoll(path)
    for b in bodies:
        if "euler_deg" in b:
            raise ValueError(f"body {b['name']!r}: give orientation as a quaternion (euler_deg is not supported here)")
    pelvis = np.array(bodies[0]["position"], dtype=float)  # the first moving body: the turning point
    # the template's lowest point, from its built bodies
    template = parse_scene({"simulation": {"gravity": sim.get("gravity", [0, 0, -9.81])},
                            "bodies": copy.deepcopy(bodies)}).world
    z_low = float(lowest_point_z(template.shapes, template.x, template.R).min())

    rng = np.random.default_rng(seed)
    yaw = rng.uniform(0.0, 2.0 * math.pi, n)
    drop = rng.uniform(heights[0], heights[1], n)
    k = grid_side(n)
    half = 0.5 * (k - 1) * spacing

    out_bodies = [{"name": "ground", "shape": {"type": "plane", "normal": [0, 0, 1]}, "fixed": True,
                   "material": {"friction": friction, "restitution": 0.0}}]
    out_joints = []
    for c in range(n):
        cz, sz = math.cos(yaw[c]), math.sin(yaw[c])
        turn = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
        q_yaw = [math.cos(0.5 * yaw[c]), 0.0, 0.0, math.sin(0.5 * yaw[c])]
        centre = np.array([(c % k) * spacing - half, (c // k) * spacing - half, drop[c] - z_low])

        def place(p, turn=turn, centre=centre):
            d = np.asarray(p, dtype=float) - pelvis
            d[2] += pelvis[2]
            return (turn @ d + centre).tolist()

        for b in bodies:
            nb = {key: copy.deepcopy(v) for key, v in b.items() if key not in ("velocity", "angular_velocity",
                                                                                  "angular_velocity_frame")}
            nb["name"] = f"{b['name']}_{c}"
            nb["position"] = place(b.get("position", [0.0, 0.0, 0.0]))
            nb["orientation"] = _quat_mul(q_yaw, b.get("orientation", [1.0, 0.0, 0.0, 0.0]))
            nb.setdefault("material", {"friction": friction, "restitution": 0.0})
            out_bodies.append(nb)
        for j in joints:
            nj = copy.deepcopy(j)
            if nj.get("frame", "world") != "world":
                raise ValueError("ragdoll joints must be given in world coordinates (frame = \"world\")")
            nj["body_a"] = f"{j['body_a']}_{c}"
            nj["body_b"] = f"{j['body_b']}_{c}"
            if "name" in nj:
                nj["name"] = f"{j['name']}_{c}"
            for key in ("anchor", "anchor_b"):
                if key in nj:
                    nj[key] = place(nj[key])
            for key in ("axis", "axis_b"):
                if key in nj:
                    nj[key] = (turn @ np.asarray(nj[key], dtype=float)).tolist()
            out_joints.append(nj)

    scene = parse_scene({"simulation": {"gravity": sim.get("gravity", [0, 0, -9.81])},
                         "bodies": out_bodies, "joints": out_joints}, file="ragdolls")
    steps = round(DURATION / DT)
    settings = {"scene": "ragdolls", "dt": DT, "substeps": SUBSTEPS, "duration": steps * DT, "steps": steps,
                "n": n, "seed": seed, "yaw": yaw, "drop_height": drop}
    return scene.world, settings


__all__ = ["RAGDOLL_TOML", "grid_side", "lowest_point_z", "ragdolls", "read_ragdoll"]
