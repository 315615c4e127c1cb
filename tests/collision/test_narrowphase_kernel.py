"""The narrowphase kernel against its pair routine, and its arrays' lifetimes.

The kernel (``narrowphase.collide_pairs``) tests GJK's first step itself before it calls the
convex routine (``convex.apart_on_centre_line``, a shortcut for the pairs that end there), and
its convex routines run without Numba's reference counting (``math3d.NO_NRT``), on scratch it
lends them. Neither may change a manifold: the kernel's rows are compared bit for bit with the
routine called alone (``collide_shapes``, which has no shortcut) on random pairs of hulls,
cylinders, cones, capsules, spheres and boxes placed around the distance where the shortcut's
answer flips. And no array may stay referenced after the kernel (a reference-count mistake
keeps one alive: weak references).
"""

import gc
import weakref

import numpy as np

import tumble as tb
from tumble.collision import SPECULATIVE_DISTANCE, build_shape_table, update_bounds
from tumble.collision.manifold import ContactManifolds
from tumble.collision.narrowphase import PAIR_WORK_ROWS, collide_pairs, collide_shapes
from tumble.collision.pairs.convex import convex_scratch


def _random_shape(rng):
    kind = rng.integers(6)
    if kind == 0:
        return tb.Convex(points=rng.normal(size=(int(rng.integers(4, 40)), 3)) * rng.uniform(0.2, 0.6, 3))
    if kind == 1:
        return tb.Cylinder(rng.uniform(0.1, 0.4), rng.uniform(0.2, 0.8))
    if kind == 2:
        return tb.Cone(rng.uniform(0.1, 0.4), rng.uniform(0.2, 0.8))
    if kind == 3:
        return tb.Capsule(rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6))
    if kind == 4:
        return tb.Sphere(rng.uniform(0.1, 0.4))
    return tb.Box(size=rng.uniform(0.2, 0.8, 3))


def _world(seed, pairs=150):
    """``pairs`` pairs of random shapes, each pair at a random gap along a random line (from
    overlapping to beyond the speculative margin), moving so that the margins differ."""
    rng = np.random.default_rng(seed)
    w = tb.World(gravity=(0, 0, 0))
    for k in range(pairs):
        centre = np.array([4.0 * k, 0.0, 0.0])
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        gap = rng.uniform(0.2, 1.4)  # moved to the contact threshold by _kernel_and_routine
        for side in (-1, 1):
            q = rng.normal(size=4)
            w.add_body(_random_shape(rng), mass=1.0, position=centre + side * 0.5 * gap * d,
                       orientation=q / np.linalg.norm(q), velocity=rng.normal(size=3),
                       angular_velocity=rng.normal(size=3))
    return w


def _table_and_bounds(w):
    """The world's shape table, its shapes' poses, boxes and margins over a step of 1/60 s, and
    the first shape of each pair (the pairs are shapes 2k and 2k + 1)."""
    table = build_shape_table(w)
    margin = np.empty(table.shape_count)
    pos, R, aabb = update_bounds(w.x, w.R, table, SPECULATIVE_DISTANCE, v=w.v, omega=w.omega, dt=1 / 60,
                                 shape_margin=margin)
    return table, pos, R, aabb, margin, np.arange(0, table.shape_count, 2, dtype=np.int64)


def _routine(table, pos, R, margin, a, b, work, scratch):
    """``collide_shapes`` on shape rows a, b (in SHAPE_* order) with the kernel's pair margin."""
    if table.shape_type[a] > table.shape_type[b]:
        a, b = b, a
    normal, point, sep, feat = np.zeros(3), np.zeros((4, 3)), np.zeros(4), np.zeros(4, dtype=np.int64)
    n = collide_shapes(table.shape_type[a], table.shape_type[b], pos[a], R[a], table.shape_params[a], pos[b], R[b],
                       table.shape_params[b], margin[a] + margin[b] - SPECULATIVE_DISTANCE, table.geometry, a, b,
                       normal, point, sep, feat, work, np.zeros((4, 3)), scratch)
    return n, normal, point[:n], sep[:n], feat[:n]


def _kernel_and_routine(seed):
    """Each pair moved along its centre line to where the routine's answer flips (contacts or
    none; bisection), then just inside or just outside it (1e-7 relative), where a shortcut that
    claimed "apart" too early or too late would show; then every pair by the kernel and by the
    routine."""
    w = _world(seed)
    table, pos, R, aabb, margin, pair_a = _table_and_bounds(w)
    pair_b = pair_a + 1
    work, scratch = np.empty((PAIR_WORK_ROWS, 3)), convex_scratch()
    for k, (a, b) in enumerate(zip(pair_a, pair_b)):
        d = pos[b] - pos[a]
        d /= np.linalg.norm(d)
        lo, hi = 0.0, 4.0  # centres together: overlapping; 4 m apart: no contact (every shape is under 1.6 m)
        for _ in range(50):
            t = 0.5 * (lo + hi)
            pos[b] = pos[a] + t * d
            lo, hi = (t, hi) if _routine(table, pos, R, margin, a, b, work, scratch)[0] else (lo, t)
        pos[b] = pos[a] + (lo * (1 - 1e-7) if k % 2 else hi * (1 + 1e-7)) * d
    out = collide_pairs(pair_a, pair_b, table, pos, R, aabb, SPECULATIVE_DISTANCE, ContactManifolds(),
                        shape_margin=margin)
    cand = out.candidates(len(pair_a))
    rows = []
    for k, (a, b) in enumerate(zip(pair_a, pair_b)):
        n, normal, point, sep, feat = _routine(table, pos, R, margin, a, b, work, scratch)
        kn = cand[2][k]
        rows.append((n, normal, point, sep, feat, kn, cand[3][k], cand[4][k, :kn], cand[5][k, :kn], cand[6][k, :kn]))
    return rows


def test_kernel_gives_the_routines_manifolds_bit_for_bit():
    """The kernel's shortcut and its scratch change nothing: every pair's count, normal, points,
    separations and features equal the routine's own (exactly: the same arithmetic), for pairs
    just inside and just outside the distance where contacts start (a shortcut with a cutoff 10 %
    short fails here: checked)."""
    with_contacts = without = 0
    for seed in range(3):
        for n, normal, point, sep, feat, kn, knormal, kpoint, ksep, kfeat in _kernel_and_routine(seed):
            assert kn == n
            if n:
                with_contacts += 1
                assert np.array_equal(knormal, normal)
                assert np.array_equal(kpoint, point)
                assert np.array_equal(ksep, sep)
                assert np.array_equal(kfeat, feat)
            else:
                without += 1
    # both kinds in numbers, so the comparison covers the shortcut's two answers
    assert with_contacts > 100 and without > 100


def test_kernel_leaves_no_array_referenced():
    """After the narrowphase (hulls, so the routines without reference counting run) and the
    table are dropped, every array the kernel read is freed: a reference counted up and never
    down (an array handed from a counted routine to an uncounted one) would keep it alive: with
    ``convex.shape_arrays`` compiled as a counted call, the hull vertices stayed (checked)."""
    w = _world(7, pairs=40)
    table, pos, R, aabb, margin, pair_a = _table_and_bounds(w)
    out = collide_pairs(pair_a, pair_a + 1, table, pos, R, aabb, SPECULATIVE_DISTANCE, ContactManifolds(),
                        shape_margin=margin)
    assert out.manifold_count > 0
    watched = [weakref.ref(a) for a in (*table.geometry, table.shape_params, pos, R, aabb, margin)]
    del table, pos, R, aabb, margin, out, w
    gc.collect()
    assert [r() is None for r in watched] == [True] * len(watched)
