"""Named contact scenes: each is a demo, a test fixture and a benchmark (STYLE 5.6 rule 7).

Every builder returns ``(world, settings)``: a ``tumble.World`` (z up) and a dict of
recommended settings ``{"dt": s, "substeps": int, "duration": s, "steps": int, ...}``
(``steps`` = duration / dt). Sleeping keeps the World's default (on, Box3D's default too),
except in large_pyramid and many_pyramids, which turn it off as Box3D does (``"sleeping": False``).
The scenes follow /work/shared/BENCHMARKS.md:

pile(n, seed=0)     BENCHMARKS "pile": n cubes of half-extent 0.1 on a k x k x k grid, falling on a plane
stack(n=10)         BENCHMARKS "stack": n cubes of half-extent 0.5 standing on a plane, 10 s
tower(n=10)         issue 3's tower of unit cubes that must stand 30 s
pyramid(rows=20)    a 2-D pyramid of unit cubes (rows (rows + 1) / 2 boxes: 210 for 20 rows)
large_pyramid()     Box3D's large_pyramid: 100 rows, 5050 cubes of 100 kg on a ground box
many_pyramids()     Box3D's many_pyramids: 14 x 14 pyramids of 55 cubes, 10 780 in all
convex_pile(layers=80)  Box3D's convex_pile: 5120 copies of a 32-point hull collapsing into a pile

Box3D's scenes are y up; here they are turned by +90 degrees about x, so Box3D's
(x, y, z) is tumble's (x, -z, y): its y (up) becomes z, and the plane its 2-D pyramids
stand in (x-y) becomes x-z. They keep Box3D's gravity (10 m/s^2) and friction (0.6).

The recommended dt / substeps are Box3D's step (1/60 s with 4 substeps, h = 1/240 s,
the peers' dt in BENCHMARKS.md) for every scene. ``substeps`` counts solver substeps per step
(one collision pass, then substeps of h = dt / substeps): in tumble that is
``Simulator(world, dt=settings["dt"], substeps=1)`` with the soft step's
``SoftStepSettings(substeps=settings["substeps"])`` (its default, 4), since the soft step
makes ``Simulator.substeps x SoftStepSettings.substeps`` substeps a step.
"""

from __future__ import annotations

import math

import numpy as np

from ..shapes import Box, Plane
from ..world import Material, World

#: Box3D's step: 1/60 s in 4 substeps (BENCHMARKS.md "Settings shared by every scene").
DT = 1.0 / 60.0
SUBSTEPS = 4


def _settings(duration: float, dt: float = DT, substeps: int = SUBSTEPS, **extra) -> dict:
    steps = round(duration / dt)
    return {"dt": dt, "substeps": substeps, "duration": steps * dt, "steps": steps, **extra}


def _ground_plane(world: World, friction: float):
    world.add_body(Plane(normal=(0.0, 0.0, 1.0)), fixed=True, name="ground",
                   material=Material(friction=friction, restitution=0.0))


def _ground_box(world: World, half_x: float, half_y: float, friction: float):
    """Box3D's static ground: a box 2 m thick whose top face is z = 0 (y = 0 in Box3D)."""
    world.add_body(Box(size=(2 * half_x, 2 * half_y, 2.0)), fixed=True, position=(0.0, 0.0, -1.0),
                   name="ground", material=Material(friction=friction, restitution=0.0))


def grid_side(n: int) -> int:
    """k = ceil(cbrt(n)) in integers (no floating-point cube-root surprises at n = 1000)."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    k = max(1, round(n ** (1.0 / 3.0)))
    while k ** 3 < n:
        k += 1
    while k > 1 and (k - 1) ** 3 >= n:
        k -= 1
    return k


def pile_layout(n: int, seed: int = 0, spacing: float = 0.4, z0: float = 0.5):
    """Centres (n, 3) m and unit quaternions (n, 4) (w, x, y, z) of the pile.

    Grid points of a k x k x k grid (k = ceil(cbrt n)) filled x fastest, then y, then z (so
    the lowest layers are full), centred on x = y = 0, lowest centres at z = ``z0``.
    Orientations: normalised 4-D Gaussian samples of ``np.random.default_rng(seed)``
    (uniform on SO(3)).
    """
    k = grid_side(n)
    idx = np.arange(n)
    half = 0.5 * (k - 1) * spacing
    pos = np.stack([(idx % k) * spacing - half, ((idx // k) % k) * spacing - half, (idx // (k * k)) * spacing + z0],
                   axis=1).astype(float)
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 0] < 0] *= -1.0  # w >= 0: the same rotation, one canonical sign
    return pos, q


def pile(n: int, seed: int = 0):
    """BENCHMARKS "pile": ``n`` cubes of half-extent 0.1, mass 1, seeded random orientation,
    falling from a k x k x k grid (0.4 m spacing, lowest centres at z = 0.5, centred on x = y = 0)
    onto the plane z = 0; gravity -9.81 z; friction 0.5, restitution 0 for every body; 4 s.

    Bodies: "ground" (index 0), then "box0" ... "box<n-1>" in grid order.
    """
    n = int(n)
    pos, q = pile_layout(n, seed)
    mat = Material(friction=0.5, restitution=0.0)
    world = World(gravity=(0.0, 0.0, -9.81))
    _ground_plane(world, 0.5)
    cube = Box(size=(0.2, 0.2, 0.2))
    for i in range(n):
        world.add_body(cube, mass=1.0, position=pos[i], orientation=q[i], material=mat, name=f"box{i}")
    k = grid_side(n)
    return world, _settings(4.0, scene="pile", n=n, seed=seed, grid=k, half_extent=0.1,
                            region_half_width=0.5 * (k - 1) * 0.4 + 2.0)


def _column(n: int, friction: float, mass: float, gravity: float, name: str, duration: float, **extra):
    world = World(gravity=(0.0, 0.0, -gravity))
    _ground_plane(world, friction)
    mat = Material(friction=friction, restitution=0.0)
    cube = Box(size=(1.0, 1.0, 1.0))
    for i in range(int(n)):
        world.add_body(cube, mass=mass, position=(0.0, 0.0, 0.5 + i), material=mat, name=f"box{i}")
    return world, _settings(duration, scene=name, n=int(n), half_extent=0.5, **extra)


def stack(n: int = 10):
    """BENCHMARKS "stack": ``n`` cubes of half-extent 0.5, mass 1, centres at z = 0.5 + i (touching,
    no gap), on the plane z = 0; gravity -9.81 z; friction 0.6, restitution 0; 10 s."""
    return _column(n, friction=0.6, mass=1.0, gravity=9.81, name="stack", duration=10.0)


def tower(n: int = 10):
    """Issue 3's tower: ``n`` unit cubes (side 1 m, Box3D's default density 1000 -> 1000 kg each)
    standing on the plane z = 0, centres at z = 0.5 + i; gravity -9.81 z; friction 0.6; 30 s
    (the acceptance test: the top drifts under 1 cm in 30 s)."""
    return _column(n, friction=0.6, mass=1000.0, gravity=9.81, name="tower", duration=30.0)


def _pyramid_boxes(world: World, rows: int, x0: float, y: float, density: float, friction: float, prefix: str):
    """One 2-D pyramid in the x-z plane at ``y``: row i = 0..rows-1 holds rows - i unit cubes at
    z = i + 0.5, x = x0 + 0.5 i + k (k = 0..rows-1-i); each row sits half a box to the right."""
    mat = Material(friction=friction, restitution=0.0)
    cube = Box(size=(1.0, 1.0, 1.0))
    for i in range(rows):
        for k in range(rows - i):
            world.add_body(cube, density=density, position=(x0 + 0.5 * i + k, y, i + 0.5), material=mat,
                           name=f"{prefix}{i}_{k}")


def pyramid(rows: int = 20):
    """A 2-D pyramid of ``rows`` rows of unit cubes (rows (rows + 1) / 2 boxes, 210 for 20 rows),
    Box3D's layout and materials (density 100 -> 100 kg a cube, friction 0.6, gravity 10), centred
    on x = 0 in the x-z plane, the bottom row resting on the plane z = 0; 10 s (issue 3: it stands)."""
    rows = int(rows)
    world = World(gravity=(0.0, 0.0, -10.0))
    _ground_plane(world, 0.6)
    _pyramid_boxes(world, rows, x0=0.5 - 0.5 * rows, y=0.0, density=100.0, friction=0.6, prefix="box")
    return world, _settings(10.0, scene="pyramid", rows=rows, n=rows * (rows + 1) // 2, half_extent=0.5)


def large_pyramid():
    """Box3D's large_pyramid (BENCHMARKS.md): a static ground box of half-extents (400, 400, 1)
    centred at z = -1 (top face z = 0), then 5050 unit cubes of density 100 (100 kg), friction 0.6,
    restitution 0, in one 2-D pyramid of 100 rows in the x-z plane (y = 0): box (i, j), j = i..99,
    at x = 0.5 (i + 1) + (j - i) - 50, z = i + 0.5. Gravity 10. 200 steps of 1/60 s with 4 substeps
    Sleeping is off (``world.sleeping = False``), as Box3D turns it off in this scene."""
    world = World(gravity=(0.0, 0.0, -10.0))
    world.sleeping = False  # b3World_EnableSleeping(false)
    _ground_box(world, 400.0, 400.0, 0.6)
    _pyramid_boxes(world, 100, x0=-49.5, y=0.0, density=100.0, friction=0.6, prefix="box")
    return world, _settings(200 * DT, scene="large_pyramid", n=5050, half_extent=0.5, sleeping=False)


def many_pyramids():
    """Box3D's many_pyramids (BENCHMARKS.md): a static ground box of half-extents (77, 77, 1) centred
    at z = -1, and 14 x 14 = 196 pyramids of base 10 (55 unit cubes each, density 100, friction 0.6),
    10 780 cubes in all. Pyramid (r, c), r, c = 0..13, stands in the plane y = 76 - r 152/13 (Box3D's
    z = -76 + r 152/13, turned), its left box centre at x = -76 + 11 c; row i = 0..9 holds 10 - i
    boxes at z = i + 0.5, x = -76 + 11 c + 0.5 i + k. Gravity 10. 100 steps of 1/60 s, 4 substeps.
    Sleeping is off (``world.sleeping = False``), as every body's in Box3D's scene."""
    world = World(gravity=(0.0, 0.0, -10.0))
    world.sleeping = False  # every body has enableSleep = false in Box3D's scene
    _ground_box(world, 77.0, 77.0, 0.6)
    for r in range(14):
        y = -(-76.0 + r * (152.0 / 13.0))
        for c in range(14):
            _pyramid_boxes(world, 10, x0=-76.0 + 11.0 * c, y=y, density=100.0, friction=0.6, prefix=f"p{r}_{c}_")
    return world, _settings(100 * DT, scene="many_pyramids", n=10780, half_extent=0.5, sleeping=False)


def convex_pile_points() -> np.ndarray:
    """(32, 3) the points of Box3D's convex_pile hull (ported by Box3D from PEEL): 32 directions
    drawn by PEEL's linear congruential generator (seed 42, state = state 2147001325 + 715136305
    mod 2^32, each coordinate (state & 0xffff) / 65535 - 0.5 in float32, rejected outside the ball
    of radius 0.5, normalised), times the amplitude 2 m; Box3D's (x, y, z), y up."""
    state = 42
    points = []
    f32 = np.float32
    while len(points) < 32:
        c = []
        for _ in range(3):
            state = (state * 2147001325 + 715136305) & 0xFFFFFFFF
            c.append(f32(state & 0xFFFF) / f32(65535.0) - f32(0.5))
        p = np.array(c, dtype=np.float32)
        if p @ p > f32(0.25):
            continue
        points.append(f32(2.0) * p / np.sqrt(p @ p, dtype=np.float32))
    return np.array(points, dtype=float)


def convex_pile(layers: int = 80):
    """Box3D's convex_pile (its benchmark from PEEL): a static ground box of half-extents (250, 250, 1)
    centred at z = -1, and 8 x 8 x ``layers`` (80: 5120) copies of one convex hull of 32 points on a
    sphere of radius 2 m (``convex_pile_points``), density 1 (Box3D's default: about 25 kg), friction
    0.6, restitution 0, on a grid 4 m apart: Box3D's (x, y, z) = ((i - 4) 4, 2 + 4 layer, (k - 4) 4),
    turned to tumble's (x, -z, y). The column collapses into a pile. Gravity 10; sleeping on (Box3D's
    default for this scene). 500 steps of 1/60 s with 4 substeps."""
    from ..shapes import Convex

    world = World(gravity=(0.0, 0.0, -10.0))
    _ground_box(world, 250.0, 250.0, 0.6)
    hull = Convex(points=convex_pile_points()[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0]))
    material = Material(friction=0.6, restitution=0.0)
    for layer in range(layers):
        for k in range(8):
            for i in range(8):
                world.add_body(hull, density=1.0, position=((i - 4) * 4.0, -((k - 4) * 4.0), 2.0 + 4.0 * layer),
                               material=material, name=f"hull{layer}_{k}_{i}")
    return world, _settings(500 * DT, scene="convex_pile", n=64 * layers)


SCENES = {
    "pile": pile,
    "stack": stack,
    "tower": tower,
    "pyramid": pyramid,
    "large_pyramid": large_pyramid,
    "many_pyramids": many_pyramids,
    "convex_pile": convex_pile,
}


def build(name: str, **kwargs):
    """``(world, settings)`` of the named scene (a key of ``SCENES``) with the builder's keyword arguments."""
    try:
        builder = SCENES[name]
    except KeyError:
        raise ValueError(f"unknown contact scene {name!r} (expected one of {', '.join(SCENES)})") from None
    return builder(**kwargs)


def box_corners(x: np.ndarray, R: np.ndarray, half: np.ndarray) -> np.ndarray:
    """World corners (N, 8, 3) of boxes with centres ``x`` (N, 3), orientations ``R`` (N, 3, 3) and
    half-extents ``half`` (N, 3) or (3,)."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    local = signs[None, :, :] * np.broadcast_to(np.asarray(half, dtype=float), (len(x), 3))[:, None, :]
    return x[:, None, :] + np.einsum("nij,nkj->nki", R, local)


def max_box_overlap(world: World) -> float:
    """Largest penetration depth (m) between any two moving boxes, or a moving box and the ground
    (plane z = 0 or a fixed box whose top is z = 0), at the current poses: a check that a scene
    starts without overlap (touching is 0). Box-box depth by the separating axis test (15 axes);
    a broad pass on bounding spheres keeps it near-linear on the grid scenes."""
    from ..shapes import Box as _Box

    moving = np.flatnonzero(world.moving)
    for i in moving:
        if not isinstance(world.shapes[i], _Box):
            raise TypeError("max_box_overlap handles box bodies only")
    x = world.x[moving]
    R = world.R[moving]
    half = np.array([world.shapes[i].half_extents for i in moving])
    corners = box_corners(x, R, half)
    depth = max(0.0, float(-corners[..., 2].min())) if len(moving) else 0.0
    radius = np.linalg.norm(half, axis=1)
    # spatial hash on cells of the largest bounding-sphere diameter
    cell = 2.0 * float(radius.max()) if len(moving) else 1.0
    keys = np.floor(x / cell).astype(np.int64)
    buckets: dict = {}
    for a, key in enumerate(map(tuple, keys)):
        buckets.setdefault(key, []).append(a)
    for a in range(len(moving)):
        ka = keys[a]
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for b in buckets.get((ka[0] + dx, ka[1] + dy, ka[2] + dz), ()):
                        if b <= a:
                            continue
                        d = x[b] - x[a]
                        if float(d @ d) >= (radius[a] + radius[b]) ** 2:
                            continue
                        depth = max(depth, _sat_depth(x[a], R[a], half[a], x[b], R[b], half[b]))
    return depth


def _sat_depth(xa, Ra, ha, xb, Rb, hb) -> float:
    """Penetration depth of two boxes along the separating axis of least overlap (0 if separated)."""
    axes = [Ra[:, k] for k in range(3)] + [Rb[:, k] for k in range(3)]
    for i in range(3):
        for j in range(3):
            c = np.cross(Ra[:, i], Rb[:, j])
            nc = float(np.linalg.norm(c))
            if nc > 1e-9:
                axes.append(c / nc)
    d = xb - xa
    best = math.inf
    for ax in axes:
        ra = float(np.sum(ha * np.abs(Ra.T @ ax)))
        rb = float(np.sum(hb * np.abs(Rb.T @ ax)))
        overlap = ra + rb - abs(float(d @ ax))
        if overlap <= 0.0:
            return 0.0
        best = min(best, overlap)
    return best
