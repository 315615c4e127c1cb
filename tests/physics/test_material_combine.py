"""Materials' combine modes (``Material.friction_combine``, ``restitution_combine``: PhysX's modes
and precedence) and margins (``Material.margin``: MuJoCo's geom margin, PhysX's rest offset).

Compared with: Coulomb's law for a block sliding to rest (deceleration mu g, mu the pair's
friction by the mode: sqrt(a b), (a + b) / 2, min, a b, max), the textbook bounce (apex e^2 h,
e the pair's restitution by the mode), and for margins the same body's rest without margins,
lifted by the margins' sum (the solver sees the gap less the margins, nothing else changes).
A world that sets neither keeps its bits (the golden hashes of tests/determinism).
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.errors import InputError

DT = 1.0 / 240.0
G = 9.81


def _slide(block, ground, v0=2.0):
    """(times (F,), block x speed (F,)) of a 0.4 m cube thrown at v0 along x on the ground."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=ground)
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=3.0, position=(0, 0, 0.2), velocity=(v0, 0, 0), material=block)
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(0.3, frame_rate=240)
    return traj.time, traj.velocity[:, box.index, 0]


@pytest.mark.parametrize("mode_block, mode_ground, mu", [
    (None, None, math.sqrt(0.8 * 0.2)),  # neither sets one: Box2D's geometric mean, as before
    ("geometric", None, math.sqrt(0.8 * 0.2)),
    ("average", None, 0.5),
    (None, "min", 0.2),
    ("multiply", None, 0.16),  # Bullet's
    ("max", None, 0.8),  # MuJoCo's
    ("average", "max", 0.8),  # the later mode of PhysX's order wins, whichever body sets it
    ("max", "average", 0.8),
    ("min", "average", 0.2),
    ("multiply", "min", 0.16),
])
def test_a_sliding_block_decelerates_by_the_pairs_combined_friction(mode_block, mode_ground, mu):
    """A cube (friction 0.8) thrown at 2 m/s on ground of friction 0.2 decelerates at mu g while
    it slides, mu by the pair's mode (the later in "geometric, average, min, multiply, max" of the
    two; neither: geometric). Tolerance 1e-4 m/s: the sled's of test_part_materials.py (the
    soft step's Coulomb friction is exact while sliding; what is left is the landing frame)."""
    block = tb.Material(friction=0.8, friction_combine=mode_block)
    ground = tb.Material(friction=0.2, friction_combine=mode_ground)
    t, vx = _slide(block, ground)
    sliding = (t > 0.02) & (t < 0.9 * min(0.3, 2.0 / (mu * G)))
    np.testing.assert_allclose(vx[sliding], 2.0 - mu * G * t[sliding], rtol=0, atol=1e-4)


@pytest.mark.parametrize("mode, e", [(None, 0.9), ("max", 0.9), ("min", 0.5), ("average", 0.7),
                                     ("multiply", 0.45), ("geometric", math.sqrt(0.45))])
def test_a_ball_bounces_by_the_pairs_combined_restitution(mode, e):
    """A ball (restitution 0.9) dropped 1 m onto ground of 0.5 (the ground sets the mode)
    bounces to e^2 h, e by the mode (none set: the larger, as before). 2 % as the sled's bounce
    (test_part_materials.py): the apex is read from 240 frames a second."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(restitution=0.5, restitution_combine=mode))
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, 1.1), material=tb.Material(restitution=0.9))
    traj = tb.Simulator(w, dt=DT).run(1.4, frame_rate=240)
    vz = traj.velocity[:, ball.index, 2]
    land = np.argmax(vz > 0)
    apex = traj.position[land:, ball.index, 2].max() - 0.1
    assert apex == pytest.approx(e * e * 1.0, rel=0.02)


def test_a_parts_combine_mode_is_its_own():
    """A compound's part with its own material mixes by its own mode: a rubber part (0.8, "max")
    on ground of 0.5 slides at mu = 0.8 where the body's material (0.3, no mode) would give
    sqrt(0.3 0.5)."""
    rubber = tb.Material(friction=0.8, friction_combine="max")
    parts = [(tb.Box((0.6, 0.6, 0.1)), (0, 0, -0.05), (1, 0, 0, 0), rubber),
             (tb.Box((0.6, 0.6, 0.1)), (0, 0, 0.05), (1, 0, 0, 0), None)]
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.5))
    sled = w.add_body(tb.Compound(parts), mass=2.0, position=(0, 0, 0.1), velocity=(2.0, 0, 0),
                      material=tb.Material(friction=0.3))
    traj = tb.Simulator(w, dt=DT).run(0.2, frame_rate=240)
    t, vx = traj.time, traj.velocity[:, sled.index, 0]
    sliding = t > 0.02
    np.testing.assert_allclose(vx[sliding], 2.0 - 0.8 * G * t[sliding], rtol=0, atol=1e-4)


# ---------------------------------------------------------------------------------------- margins
def _rest(shape, margin_body, margin_ground, half_height, seconds=2.0):
    """(height of the body's lowest point above the ground, its speed, the contacts) after
    ``seconds`` on the ground, sleeping off (so that every run takes the same steps)."""
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = False
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(margin=margin_ground))
    body = w.add_body(shape, mass=1.0, position=(0, 0, 0.3), euler_deg=(0, 0, 20),
                      material=tb.Material(margin=margin_body))
    sim = tb.Simulator(w, dt=DT)
    sim.run(seconds)
    return body.x[2] - half_height, float(np.linalg.norm(body.v)), sim.contacts()


@pytest.mark.parametrize("shape, half_height", [(tb.Sphere(0.1), 0.1), (tb.Box((0.2, 0.2, 0.2)), 0.1),
                                                (tb.Capsule(radius=0.1, length=0.2), 0.2)],  # upright
                         ids=["sphere", "box", "capsule"])
def test_bodies_rest_their_two_margins_apart(shape, half_height):
    """A body rests the sum of its and the ground's margins higher than without them, to 5e-6 m:
    the solver sees the gap less the margins, and rests either just in it (the soft contact's
    sag under its weight, 4.3e-6 m) or, landing on the speculative side, on it (no sag: the
    ball with margins, measured); at rest (1e-6 m/s); its contacts carry its weight (1e-6) and
    report the geometric gap."""
    base, _, _ = _rest(shape, 0.0, 0.0, half_height)
    for mb, mg in ((0.01, 0.0), (0.0, 0.02), (0.01, 0.02)):
        h, speed, contacts = _rest(shape, mb, mg, half_height)
        assert abs(base) < 5e-6
        assert h == pytest.approx(mb + mg, abs=5e-6)
        assert speed < 1e-6
        assert len(contacts) > 0
        np.testing.assert_allclose(contacts.separation, mb + mg, atol=5e-6)
        np.testing.assert_allclose(contacts.normal_impulse.sum() / DT, G, rtol=1e-6)


def test_a_fast_ball_stops_at_the_margin_without_passing_a_thin_wall():
    """Continuous collision with margins: a 1 cm ball at 100 m/s at a 1 cm thick wall (#3's
    acceptance case) with margins 5 mm each stops short of it (never closer than the margins
    less 1 mm: the speculative contact closes the gap less the margins in the substep it reaches
    them) and never passes."""
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Box((0.01, 1.0, 1.0)), fixed=True, position=(1.0, 0, 0), material=tb.Material(margin=0.005))
    ball = w.add_body(tb.Sphere(0.005), mass=0.01, position=(0, 0, 0), velocity=(100.0, 0, 0),
                      material=tb.Material(margin=0.005))
    traj = tb.Simulator(w, dt=DT).run(0.1, frame_rate=240)
    x = traj.position[:, ball.index, 0]
    closest = (1.0 - 0.005) - (x.max() + 0.005)
    assert closest > 0.01 - 1e-3
    assert np.all(x < 1.0)


@pytest.mark.parametrize("make, key", [
    (lambda: tb.Material(margin=-0.01), "margin"),
    (lambda: tb.Material(margin=float("nan")), "margin"),
    (lambda: tb.Material(friction_combine="maximum"), "friction_combine"),
    (lambda: tb.Material(restitution_combine=1), "restitution_combine"),
    (lambda: tb.Material(condim=2), "condim"),
    (lambda: tb.Material(condim=True), "condim"),
    (lambda: tb.Compound([(tb.Sphere(0.1), (0, 0, 0), (1, 0, 0, 0), tb.Material(margin=0.01))]),
     "parts[0].material.margin"),
])
def test_bad_margins_and_modes_are_one_line(make, key):
    with pytest.raises(InputError) as err:
        make()
    assert err.value.key == key and "\n" not in str(err.value)


def test_a_scene_file_sets_margins_and_modes_and_refuses_bad_ones(tmp_path):
    """Scene keys ``material.margin``, ``material.friction_combine``: the same bodies as the API's;
    a bad mode is one line naming the key."""
    from tumble.scene import load_scene

    text = """
[simulation]
gravity = [0, 0, -9.81]
[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true
material = { friction = 0.2, margin = 0.02 }
[[bodies]]
name = "box"
shape = { type = "box", size = [0.4, 0.4, 0.4] }
mass = 3.0
position = [0, 0, 0.25]
material = { friction = 0.8, friction_combine = "MODE" }
"""
    path = tmp_path / "scene.toml"
    path.write_text(text.replace("MODE", "max"))
    scene = load_scene(path)
    assert scene.world.materials[0].margin == 0.02
    assert scene.world.materials[1].friction_combine == "max"
    path.write_text(text.replace("MODE", "largest"))
    with pytest.raises(InputError) as err:
        load_scene(path)
    assert "bodies[1].material.friction_combine" in str(err.value) and "\n" not in str(err.value)


def test_a_checkpoint_keeps_margins_and_modes_bit_for_bit(tmp_path):
    """A run resumed from a checkpoint (``Simulator.save_checkpoint``) keeps the bodies' margins and
    combine modes: the same bits as the straight run (which a ground without its margin and mode
    does not give)."""
    from tumble.checks import state_hash

    def world():
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.2, margin=0.01, friction_combine="max"))
        w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=3.0, position=(0, 0, 0.25), velocity=(2, 0, 0),
                   material=tb.Material(friction=0.8, restitution=0.3, restitution_combine="min", margin=0.005))
        return w

    straight = tb.Simulator(world(), dt=DT)
    straight.step(60)
    first = tb.Simulator(world(), dt=DT)
    first.step(30)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.world.materials[0] == first.world.materials[0]
    assert resumed.world.materials[1] == first.world.materials[1]
    resumed.step(30)
    assert state_hash(resumed.world) == state_hash(straight.world)
    plain = world()  # the same scene without the ground's margin and mode: other bits
    plain.materials[0] = tb.Material(friction=0.2)
    other = tb.Simulator(plain, dt=DT)
    other.step(60)
    assert state_hash(other.world) != state_hash(straight.world)


def test_combine_modes_go_to_usd_and_back_as_physx_attributes(tmp_path):
    """``tb.save_usd`` writes a material's modes as PhysX's ``physxMaterial:frictionCombineMode`` /
    ``restitutionCombineMode`` tokens and ``tb.load_usd`` reads them back: the reloaded block slides
    at the max rule's deceleration (0.8 g; tumble's default rule would give sqrt(0.16) g), as the
    original does. A bad token in a file is one line naming the material."""
    pxr = pytest.importorskip("pxr")
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.2), name="ground")
    w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=3.0, position=(0, 0, 0.2), velocity=(2, 0, 0), name="block",
               material=tb.Material(friction=0.8, friction_combine="max", restitution_combine="min"))
    path = tmp_path / "blocks.usda"
    tb.save_usd(w, path)
    back = tb.World(gravity=(0, 0, -G))
    tb.load_usd(back, path)
    block = next(i for i, n in enumerate(back.names) if n.endswith("block"))
    assert back.materials[block].friction_combine == "max"
    assert back.materials[block].restitution_combine == "min"
    traj = tb.Simulator(back, dt=DT).run(0.2, frame_rate=240)
    t, vx = traj.time, traj.velocity[:, block, 0]
    sliding = t > 0.02
    np.testing.assert_allclose(vx[sliding], 2.0 - 0.8 * G * t[sliding], rtol=0, atol=1e-4)

    stage = pxr.Usd.Stage.Open(str(path))
    for prim in stage.Traverse():
        attr = prim.GetAttribute("physxMaterial:frictionCombineMode")
        if attr and attr.HasAuthoredValue():
            attr.Set("largest")
    stage.GetRootLayer().Export(str(tmp_path / "bad.usda"))
    with pytest.raises(InputError) as err:
        tb.load_usd(tb.World(), tmp_path / "bad.usda")
    assert "friction_combine" in str(err.value) and "largest" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("condim_block, condim_ground, mu", [
    (1, 1, 0.0),  # MuJoCo's condim 1 on both: a frictionless contact
    (1, None, math.sqrt(0.8 * 0.2)),  # a body without one counts as 6: the pair has friction
    (1, 3, math.sqrt(0.8 * 0.2)),  # the larger of the two
    (3, 4, math.sqrt(0.8 * 0.2)),
])
def test_a_pairs_condim_is_the_larger_and_1_slides_without_friction(condim_block, condim_ground, mu):
    """MuJoCo's rule for a pair's contact dimensions (``Material.condim``): the larger of its two
    bodies'; 1 is frictionless (the block glides on at 2 m/s to 1e-9), above it Coulomb's mu g."""
    block = tb.Material(friction=0.8, condim=condim_block)
    ground = tb.Material(friction=0.2, condim=condim_ground)
    t, vx = _slide(block, ground)
    if mu == 0.0:
        np.testing.assert_allclose(vx, 2.0, rtol=0, atol=1e-9)
        return
    sliding = (t > 0.02) & (t < 0.3)
    np.testing.assert_allclose(vx[sliding], 2.0 - mu * G * t[sliding], rtol=0, atol=1e-4)


@pytest.mark.parametrize("condim, brakes", [(3, False), (4, True), (None, True)])
def test_spinning_friction_needs_a_condim_of_4(condim, brakes):
    """A ball spinning in place about the vertical (10 rad/s) with spinning friction 0.001 m on
    both sides: braked by the torque s N (its spin falls by s m g / I per second, as
    test_contact_rolling_resistance.py checks) unless the pair's condim is below 4 (MuJoCo's
    torsional friction comes with condim 4), where it spins on to 1e-9."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(spinning_friction=0.001, condim=condim))
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, 0.1), angular_velocity=(0, 0, 10.0),
                      material=tb.Material(spinning_friction=0.001, condim=condim))
    tb.Simulator(w, dt=DT).run(0.5)
    spin = ball.omega[2]
    if brakes:
        inertia = 0.4 * 1.0 * 0.1 ** 2
        assert spin == pytest.approx(10.0 - 0.001 * G / inertia * 0.5, abs=1e-9)
    else:
        assert spin == pytest.approx(10.0, abs=1e-9)


def test_save_usd_says_what_it_leaves_out_of_a_material(tmp_path):
    """Margins, MuJoCo's condim and the geometric mode have no place in UsdPhysics nor PhysX's
    material: ``tb.save_usd`` warns that it left them out, naming each."""
    pytest.importorskip("pxr")
    w = tb.World()
    w.add_body(tb.Sphere(0.1), mass=1.0, material=tb.Material(margin=0.01, condim=1, friction_combine="geometric"))
    with pytest.warns(UserWarning) as caught:
        tb.save_usd(w, tmp_path / "a.usda")
    message = " ".join(str(c.message) for c in caught)
    assert "margins" in message and "condim" in message and "geometric combine mode" in message


def test_combining_is_symmetric_and_each_mode_is_its_formula():
    """``contact_solve.combine_material`` on random coefficients and every pair of modes (unset
    included): the pair's order does not matter (a contact's normal may point either way), and
    the value is the formula of the later mode (or the default), against NumPy's."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from tumble.material import COMBINE_MODES, FRICTION_DEFAULT_MODE
    from tumble.solver.contact_solve import combine_materials_kernel

    formulas = {"geometric": lambda a, b: np.sqrt(a * b), "average": lambda a, b: 0.5 * (a + b),
                "min": np.minimum, "multiply": lambda a, b: a * b, "max": np.maximum}
    modes = st.sampled_from([None, *COMBINE_MODES])

    @settings(max_examples=200, deadline=None)
    @given(st.floats(0, 2), st.floats(0, 2), modes, modes)
    def check(a, b, mode_a, mode_b):
        codes = np.array([tb.Material(friction_combine=mode_a).combine_codes(),
                          tb.Material(friction_combine=mode_b).combine_codes()], dtype=np.int64)
        values = np.array([a, b])
        out, out2 = np.zeros(2), np.zeros(2)
        combine_materials_kernel(np.array([0, 1]), np.array([1, 0]), values, values, codes, out, out2)
        assert out[0] == out[1]
        chosen = [COMBINE_MODES.index(m) for m in (mode_a, mode_b) if m is not None]
        mode = COMBINE_MODES[max(chosen)] if chosen else COMBINE_MODES[FRICTION_DEFAULT_MODE]
        assert out[0] == pytest.approx(float(formulas[mode](a, b)), rel=1e-15, abs=0)

    check()


def test_a_pair_material_replaces_the_mix_and_survives_a_checkpoint(tmp_path):
    """``World.set_pair_material``: the contacts of that body pair take its friction (the block
    slides at 0.05 g where its material and the ground's mix to sqrt(0.8 0.2) g), condim 1 makes
    them frictionless, None gives the mix back; a body with itself is one line; a checkpoint keeps
    the pair (the resumed run's bits are the straight run's)."""
    from tumble.checks import state_hash

    def world(pair):
        w = tb.World(gravity=(0, 0, -G))
        ground = w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.2))
        box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=3.0, position=(0, 0, 0.2), velocity=(2, 0, 0),
                         material=tb.Material(friction=0.8))
        if pair is not None:
            w.set_pair_material(box, ground, pair)
        return w, box

    for pair, mu in ((tb.Material(friction=0.05), 0.05), ({"friction": 0.9, "condim": 1}, 0.0),
                     (None, math.sqrt(0.8 * 0.2))):
        w, box = world(pair)
        traj = tb.Simulator(w, dt=DT).run(0.2, frame_rate=240)
        t, vx = traj.time, traj.velocity[:, box.index, 0]
        sliding = t > 0.02
        np.testing.assert_allclose(vx[sliding], 2.0 - mu * G * t[sliding], rtol=0, atol=1e-4)
    w, box = world(tb.Material(friction=0.05))
    w.set_pair_material(0, 1, None)
    assert not w.pair_materials
    with pytest.raises(InputError) as err:
        w.set_pair_material(box, box, tb.Material())
    assert err.value.key == "body_b" and "\n" not in str(err.value)

    straight = tb.Simulator(world(tb.Material(friction=0.05))[0], dt=DT)
    straight.step(48)
    first = tb.Simulator(world(tb.Material(friction=0.05))[0], dt=DT)
    first.step(24)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.world.pair_materials == first.world.pair_materials
    resumed.step(24)
    assert state_hash(resumed.world) == state_hash(straight.world)


def test_a_scene_file_gives_contact_pairs_and_refuses_bad_ones(tmp_path):
    """``[[contact_pairs]] bodies = [A, B], material = {...}`` is ``World.set_pair_material``; an
    unknown body, one body twice or a bad material key is one line naming the key."""
    from tumble.scene import load_scene

    text = """
[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true
[[bodies]]
name = "box"
shape = { type = "box", size = [0.4, 0.4, 0.4] }
mass = 3.0
position = [0, 0, 0.25]
[[contact_pairs]]
bodies = ["box", "OTHER"]
material = { friction = 0.05, MATERIAL }
"""
    path = tmp_path / "scene.toml"
    path.write_text(text.replace("OTHER", "ground").replace("MATERIAL", "condim = 3"))
    world = load_scene(path).world
    assert world.pair_materials == {(0, 1): tb.Material(friction=0.05, condim=3)}
    for other, material, key in (("floor", "condim = 3", "contact_pairs[0].bodies[1]"),
                                 ("box", "condim = 3", "contact_pairs[0].bodies"),
                                 ("ground", "condim = 2", "contact_pairs[0].material.condim")):
        path.write_text(text.replace("OTHER", other).replace("MATERIAL", material))
        with pytest.raises(InputError) as err:
            load_scene(path)
        assert key in str(err.value) and "\n" not in str(err.value)
