"""Collision filters and exclusions (``collision/filter.py``) in the narrowphase.

The rule is compared with Box2D's ``b2ShouldShapesCollide`` written out case by case (the
table below), and the narrowphase with that rule: on jumbles of touching shapes, the body
pairs that get contacts with filters are exactly the pairs that touch without them and that
the rule allows, with the same manifolds to the bit (a filter removes pairs, never changes
one). Every kernel is checked: the box and sphere families, the dispatch over every routine
(hulls, cylinders, cones, capsules), each serial and in parallel chunks.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tumble as tb
from tumble.collision import CollisionPipeline
from tumble.collision import narrowphase as NP
from tumble.collision.filter import ALL_CATEGORIES, CollisionFilter, filter_table
from tumble.errors import InputError

F = CollisionFilter

# (filter a, filter b, collide?) after Box2D v3's b2ShouldShapesCollide:
#   same non-zero group -> group > 0; else (a.category & b.mask) and (b.category & a.mask)
RULE = [
    (F(), F(), True),                                           # defaults touch
    (F(category=2, mask=1), F(category=2, mask=1), False),      # debris passes through debris
    (F(category=2, mask=1), F(), True),                         # ... and lands on the ground
    (F(mask=0), F(), False),                                    # a mask of nothing touches nothing
    (F(), F(category=2, mask=2), False),                        # either side can refuse
    (F(category=1, mask=1, group=3), F(category=4, mask=4, group=3), True),   # positive group beats bits
    (F(group=-3), F(group=-3), False),                          # negative group beats bits
    (F(group=-3), F(group=-4), True),                           # different groups: bits decide
    (F(group=-3), F(), True),
    (F(category=8, mask=8, group=-3), F(category=1, mask=1, group=2), False),
    (F(category=ALL_CATEGORIES, mask=ALL_CATEGORIES), F(category=1 << 31, mask=1 << 31), True),
]


@pytest.mark.parametrize("a, b, expected", RULE)
def test_rule_is_box2ds(a, b, expected):
    assert a.collides_with(b) is expected
    assert b.collides_with(a) is expected


filters = st.builds(F, category=st.integers(0, 15), mask=st.integers(0, 15), group=st.integers(-2, 2),
                    env=st.sampled_from([0, 0, 1, 2]))


@given(filters, filters)
def test_rule_is_symmetric(a, b):
    assert a.collides_with(b) == b.collides_with(a)


def test_default_filters_give_an_empty_table_so_the_kernels_skip_the_test():
    assert filter_table([F(), F(), F()]).shape == (0, 4)
    table = filter_table([F(), F(category=2, mask=5, group=-1), F(env=3)])
    assert table.tolist() == [[1, ALL_CATEGORIES, 0, 0], [2, 5, -1, 0], [1, ALL_CATEGORIES, 0, 3]]


def test_bodies_of_two_envs_never_collide_and_env_0_meets_every_env():
    """``env``: two different non-zero envs never collide, whatever the bits and a shared positive
    group; the same env, or env 0 on either side, leaves it to the bits and group."""
    assert not F(env=1).collides_with(F(env=2))
    assert not F(env=1, group=3).collides_with(F(env=2, group=3))
    assert F(env=1).collides_with(F(env=1)) and F(env=1).collides_with(F()) and F().collides_with(F(env=7))
    assert not F(env=1, mask=0).collides_with(F())
    with pytest.raises(InputError, match="env: must be between 0 and 2147483647, got -1"):
        F(env=-1)


def test_filter_values_are_checked():
    with pytest.raises(InputError, match="category: must be between 0 and 0xffffffff, got -1"):
        F(category=-1)
    with pytest.raises(InputError, match="mask: expected an integer, got 1.0"):
        F(mask=1.0)
    with pytest.raises(InputError, match="collision_filter: unknown key 'layer'"):
        F.coerce({"layer": 1})
    w = tb.World()
    with pytest.raises(InputError, match="collision_filter.group: expected an integer, got 'a'"):
        w.add_body(tb.Sphere(1), mass=1, collision_filter={"group": "a"})
    # a record's own errors keep their key once (not "material.material")
    with pytest.raises(InputError, match="^collision_filter: unknown key 'layer'"):
        w.add_body(tb.Sphere(1), mass=1, collision_filter={"layer": 1})
    with pytest.raises(InputError, match="^material: expected a Material or a mapping, got 3"):
        w.add_body(tb.Sphere(1), mass=1, material=3)
    a = w.add_body(tb.Sphere(1), mass=1)
    with pytest.raises(InputError, match="cannot be excluded from itself"):
        w.exclude_collision(a, a)
    with pytest.raises(InputError, match="unknown body 'x'"):
        w.exclude_collision(a, "x")


SHAPES = {
    "boxes": lambda i: tb.Box((1.0, 0.8, 0.9)),
    "spheres": lambda i: tb.Sphere(0.5),
    "mixed": lambda i: [tb.Box((1.0, 0.8, 0.9)), tb.Sphere(0.5), tb.Capsule(0.3, 0.6), tb.Cylinder(0.4, 0.8),
                        tb.Cone(0.5, 0.9), tb.Convex(points=np.random.default_rng(i).normal(size=(12, 3)) * 0.4)][i % 6],
}
# a small palette, so that every rule case occurs among neighbours
PALETTE = [F(), F(category=2, mask=1), F(category=2, mask=3), F(group=-1), F(category=4, mask=4, group=1), F(mask=0)]


def _jumble(kind, n, seed):
    """A plane and n shapes in a 0.9 m grid of 1 m cells, turned at random and pushed into each
    other and the plane (tests/collision/test_families.py's jumble), with filters drawn from
    PALETTE and a few pairs excluded."""
    rng = np.random.default_rng(seed)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, collision_filter=F(category=1 | 2))
    for i in range(n):
        pos = (0.9 * (i % 4), 0.9 * ((i // 4) % 4), 0.45 + 0.9 * (i // 16) + 0.05 * rng.standard_normal())
        w.add_body(SHAPES[kind](i), mass=1.0, position=pos, euler_deg=tuple(rng.uniform(-180, 180, 3)),
                   collision_filter=PALETTE[rng.integers(len(PALETTE))])
    return w


def _pairs(contacts):
    m = contacts.manifold_count
    return {(int(a), int(b)) for a, b in zip(contacts.manifold_body_a[:m], contacts.manifold_body_b[:m])}


def _manifolds(contacts):
    """Per body pair: (normal, points, separations, keys) of its manifolds."""
    out = {}
    for k in range(contacts.manifold_count):
        a, b = int(contacts.manifold_body_a[k]), int(contacts.manifold_body_b[k])
        first, count = int(contacts.manifold_first[k]), int(contacts.manifold_point_count[k])
        sl = slice(first, first + count)
        out.setdefault((a, b), []).append((contacts.manifold_normal[k].tobytes(), contacts.contact_point[sl].tobytes(),
                                            contacts.contact_separation[sl].tobytes(), contacts.contact_key[sl].tobytes()))
    return out


@pytest.mark.parametrize("kind", ["boxes", "spheres", "mixed"])
@pytest.mark.parametrize("parallel", [False, True])
def test_narrowphase_keeps_exactly_the_touching_pairs_the_filters_allow(kind, parallel, monkeypatch):
    monkeypatch.setattr(NP, "PARALLEL_MIN_CANDIDATES", 0 if parallel else 10 ** 9)
    w = _jumble(kind, 48, seed=5)
    w.exclude_collision(1, 2)
    w.exclude_collision(0, 5)
    filtered = CollisionPipeline(w).detect()
    got, got_manifolds = _pairs(filtered), _manifolds(filtered)

    saved = list(w.collision_filters), set(w.excluded_collisions)
    w.collision_filters[:] = [F()] * w.body_count
    w.excluded_collisions.clear()
    w.filter_version += 1
    every = CollisionPipeline(w).detect()
    touching, every_manifolds = _pairs(every), _manifolds(every)
    w.collision_filters[:], w.excluded_collisions = saved[0], saved[1]

    allowed = {p for p in touching if w.should_collide(*p)}
    # the jumble must exercise both outcomes, or this comparison proves nothing
    assert len(allowed) > 10 and len(touching - allowed) > 10
    assert {(1, 2), (0, 5)} & touching == {(1, 2), (0, 5)} & set(every_manifolds)
    assert got == allowed
    for pair in got:
        assert got_manifolds[pair] == every_manifolds[pair], pair


def test_pipeline_rereads_filters_and_exclusions_when_they_change():
    w = tb.World()
    w.add_body(tb.Plane(), fixed=True, name="ground")
    box = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 0.45), name="box")
    pipe = CollisionPipeline(w)
    assert pipe.detect().manifold_count == 1
    box.collision_filter = {"mask": 2}  # the ground is category 1
    assert pipe.detect().manifold_count == 0
    box.collision_filter = None
    assert pipe.detect().manifold_count == 1
    w.exclude_collision("box", "ground")
    assert pipe.detect().manifold_count == 0
    assert not w.should_collide("box", "ground")


def test_jointed_pairs_and_world_exclusions_are_both_culled():
    """The soft step's jointed pairs (collide_connected false) are merged with the World's own
    exclusions: neither replaces the other."""
    w = tb.World()
    w.add_body(tb.Plane(), fixed=True, name="ground")
    a = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 0.45), name="a")
    b = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 1.4), name="b")
    c = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 2.35), name="c")
    w.add_joint(tb.HingeJoint(body_a=a, body_b=b, anchor=(0, 0, 0.95), axis=(1, 0, 0)))
    w.exclude_collision("b", "c")
    sim = tb.Simulator(w)
    sim.step(1)
    pairs = {tuple(sorted((w.names[i], w.names[j]))) for i, j in
             zip(sim.contacts().body_a, sim.contacts().body_b)}
    assert pairs == {("a", "ground")}
    assert not w.should_collide(a, b) and not w.should_collide(b, c) and w.should_collide(a, c)


def test_bodies_whose_filter_meets_nobody_do_not_switch_the_collision_stages_on():
    """``SoftStep.has_collisions``: a body of category 0 or mask 0 outside a positive group touches
    no body (the rule above), so a world of such bodies (a robot whose links have no collision shape,
    only marker spheres) has nothing for the collision stages to do and skips them; one default body
    beside them does not change that (it alone touches nothing), two do; a positive group shared by
    two such bodies makes them touch again. The answer follows filter changes."""
    from tumble.solver.soft_step import SoftStep

    def world(*filters):
        w = tb.World()
        for i, f in enumerate(filters):
            w.add_body(tb.Sphere(0.1), mass=1.0, position=(0.05 * i, 0, 0), name=f"b{i}", collision_filter=f)
        return SoftStep(w)

    none = F(category=0, mask=0)
    assert not world(none, none, none).has_collisions()
    assert not world(F(mask=0), F(category=0), F()).has_collisions()
    assert world(none, F(), F()).has_collisions()
    assert world(F(category=0, mask=0, group=2), F(category=0, mask=0, group=2)).has_collisions()
    step = world(none, none)
    assert not step.has_collisions()
    step.world.body("b1").collision_filter = None
    step.world.body("b0").collision_filter = None
    assert step.has_collisions()


@given(st.lists(filters, min_size=1, max_size=12))
def test_live_filters_are_the_bodies_that_some_other_body_may_touch(fs):
    """``filter.live_filters`` (decided over the distinct rows at once) against the rule applied to
    every pair of bodies: a body is live when some other body's filter and its own allow contact."""
    from tumble.collision.filter import live_filters

    table = np.array([(f.category, f.mask, f.group, f.env) for f in fs], dtype=np.int64).reshape(-1, 4)
    expected = [any(a.collides_with(b) for j, b in enumerate(fs) if j != i) for i, a in enumerate(fs)]
    assert live_filters(table).tolist() == expected


def test_copies_in_disjoint_categories_skip_the_collision_stages_and_stay_visible_to_rays():
    """Bodies whose category no body's mask holds (tumble.envs gives a model that touches nothing
    category 1 << 31, mask 1 << 30) touch nothing, so the stages are skipped, as for mask 0; unlike
    mask 0 a ray with the default filter still sees them (a camera draws them)."""
    from tumble.solver.soft_step import SoftStep

    w = tb.World()
    for i in range(3):
        w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, 0.05 * i), name=f"b{i}",
                   collision_filter=F(category=1 << 31, mask=1 << 30))
    assert not SoftStep(w).has_collisions()
    hit = w.ray_cast(origin=(0, 0, 5), direction=(0, 0, -1))
    assert hit.body[0] == 2


def test_an_mjcf_model_of_visual_geoms_takes_no_collision_stages(tmp_path):
    """An MJCF chain whose geoms are all contype = conaffinity = 0 (visual) gets marker spheres that
    touch nothing: the soft step skips the collision stages (the same motion: the stages found no
    contact), and with its geoms colliding it takes them."""
    import tumble as tb

    def chain(contype):
        body = "".join(f'<body name="l{i}" pos="{0 if i == 0 else 0.1} 0 {1 if i == 0 else 0}"><joint type="ball"/>'
                       f'<geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" contype="{contype}" '
                       f'conaffinity="{contype}"/>' for i in range(4)) + "</body>" * 4
        path = tmp_path / f"chain{contype}.xml"
        path.write_text(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
        w = tb.World(gravity=(0, 0, -9.81))
        tb.load_mjcf(w, path)
        sim = tb.Simulator(w)
        sim.step(1)
        return sim

    assert not chain(0).soft_step.has_collisions()
    assert chain(1).soft_step.has_collisions()


def test_a_checkpoint_keeps_the_envs_and_the_resumed_run_its_bits(tmp_path):
    """Two boxes stacked in one spot in envs 1 and 2 over a floor of env 0: they pass through each
    other and both rest on the floor (each at its half-height, 0.05 m, to the soft contact's
    compression: 4e-6 m), where boxes of one env would stack; a checkpoint keeps each body's env and the
    run resumed from it ends in the same bits as the run that went on."""
    def world(envs):
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Plane(), fixed=True, name="floor")
        for k, env in enumerate(envs):
            w.add_body(tb.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.3 + 0.25 * k), name=f"box{k}",
                       collision_filter=F(env=env))
        return w

    apart = tb.Simulator(world([1, 2]), dt=1 / 240)
    apart.step(240)
    z = apart.world.x[1:, 2]
    assert np.abs(z - 0.05).max() < 1e-4
    stacked = tb.Simulator(world([1, 1]), dt=1 / 240)
    stacked.step(240)
    assert stacked.world.x[2, 2] > 0.149
    path = apart.save_checkpoint(tmp_path / "run.ckpt")
    apart.step(24)
    resumed = tb.Simulator.load_checkpoint(path)
    assert [f.env for f in resumed.world.collision_filters] == [0, 1, 2]
    resumed.step(24)
    assert np.array_equal(resumed.world.x, apart.world.x)
