"""MJCF geoms' surfaces against MuJoCo itself: the pair's friction is the larger of the two geoms'
(MuJoCo's rule, ``Material.friction_combine = "max"``), and with ``load_mjcf(margins=True)`` a
pair rests its two ``margin``s apart (MuJoCo sums them: measured on MuJoCo 3 and 4).

Compared with: the same file stepped by MuJoCo (its contacts are soft: it sinks about 1e-4 m
under a 1 kg ball with its default solref, and its friction cone is pyramidal, so the figures
are compared to those sizes), and Coulomb's law (a block sliding at the pair's friction
decelerates at mu g).
"""

import pathlib

import numpy as np
import pytest

import tumble as tb
from tumble.errors import InputError

mujoco = pytest.importorskip("mujoco")

G = 9.81

BALL = """<mujoco><option timestep="0.002"/>
<worldbody><geom name="floor" type="plane" size="5 5 .1" margin="FLOOR"/>
<body name="ball" pos="0 0 0.3"><freejoint/><geom type="sphere" size="0.1" mass="1" margin="BALL"/></body>
</worldbody></mujoco>"""


def _ball(tmp_path, ball, floor):
    path = tmp_path / "ball.xml"
    path.write_text(BALL.replace("FLOOR", str(floor)).replace("BALL", str(ball)))
    return path


def _mujoco_rest(path, seconds=3.0):
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=int(seconds / m.opt.timestep))
    return d.qpos.copy(), d.qvel.copy()


@pytest.mark.parametrize("ball, floor", [(0.01, 0.0), (0.0, 0.02), (0.01, 0.02)])
def test_a_ball_rests_its_margins_above_the_floor_as_in_mujoco(tmp_path, ball, floor):
    """A 0.1 m ball on the file's floor rests the two margins' sum above it, as in MuJoCo, to 2e-4 m
    (MuJoCo's soft contact sinks 3.7e-4 m under it, measured; tumble's 4e-6 m): to 5e-4 m. Without
    ``margins=True`` (the default) the file's margins are not read: it rests on the floor."""
    path = _ball(tmp_path, ball, floor)
    qpos, qvel = _mujoco_rest(path)
    for margins, expected in ((True, ball + floor), (False, 0.0)):
        world = tb.World(gravity=(0, 0, -G))
        robot = tb.load_mjcf(world, path, margins=margins)
        sim = tb.Simulator(world, dt=1 / 240)
        sim.run(3.0)
        z = robot.links["ball"].x[2] - 0.1
        assert z == pytest.approx(expected, abs=2e-5)
        if margins:
            assert z == pytest.approx(qpos[2] - 0.1, abs=5e-4)
    assert qpos[2] - 0.1 == pytest.approx(ball + floor, abs=5e-4)  # MuJoCo sums the two
    assert np.abs(qvel).max() < 1e-6


def _mujoco_slide(path, window):
    """(MuJoCo's mean x deceleration over the second of two windows of ``window`` s, m/s^2; its
    final qpos) of the file's free body thrown at 2 m/s along x."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qvel[0] = 2.0
    mujoco.mj_step(m, d, nstep=int(window / m.opt.timestep))
    v1 = d.qvel[0]
    mujoco.mj_step(m, d, nstep=int(window / m.opt.timestep))
    return (v1 - d.qvel[0]) / window, d.qpos.copy()


BLOCK = """<mujoco><option timestep="0.0005" cone="elliptic"/>
<worldbody><geom name="floor" type="plane" size="5 5 .1" friction="0.9" condim="FLOOR"/>
<body name="block" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1" friction="0.3"
 condim="BLOCK"/></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("block_condim, floor_condim, mu", [(3, 3, 0.9), (1, 3, 0.9), (1, 1, 0.0)])
def test_a_block_slides_at_the_larger_of_the_two_frictions_as_in_mujoco(tmp_path, block_condim, floor_condim, mu):
    """A block of friction 0.3 thrown at 2 m/s on a floor of 0.9 decelerates at 0.9 g in both
    engines (MuJoCo's max rule; tumble's own sqrt(0.3 0.9) = 0.52 would let it slide 74 % further),
    the pair's condim being the larger of the two geoms'; with condim 1 on both it glides without
    friction in both. tumble's speed while sliding to 1e-4 m/s of Coulomb's (the soft step's
    friction is exact while sliding), MuJoCo's (its elliptic cone: the pyramidal default slows it
    at 0.79 g, not the cone's 0.9 g) to 2 % of 0.9 g."""
    path = tmp_path / "block.xml"
    path.write_text(BLOCK.replace("FLOOR", str(floor_condim)).replace("BLOCK", str(block_condim)))
    deceleration, _ = _mujoco_slide(path, 0.1)
    assert deceleration == pytest.approx(mu * G, abs=0.02 * 0.9 * G)

    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    block = robot.links["block"]
    block.v = (2.0, 0.0, 0.0)
    sim = tb.Simulator(world, dt=1 / 240)
    traj = sim.run(0.2, frame_rate=240)
    t = traj.time
    vx = traj.velocity[:, block.index, 0]
    sliding = t > 0.02
    np.testing.assert_allclose(vx[sliding], 2.0 - mu * G * t[sliding], rtol=0, atol=1e-4)


def test_gymnasiums_ant_stands_at_mujocos_height_with_its_margins(tmp_path):
    """Gymnasium's ant (margin 0.01 on every geom, the floor's too) let go from its model pose
    stands with its torso at MuJoCo's height to 1 mm with ``margins=True`` (measured 0.38261
    against 0.38248 m: MuJoCo's soft contacts sink a little); 2 cm lower without them (its feet
    on the floor where MuJoCo's stand 0.02 m above it)."""
    gymnasium = pytest.importorskip("gymnasium")
    path = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"
    qpos, _ = _mujoco_rest(path, seconds=15.0)
    for margins, offset in ((True, 0.0), (False, 0.02)):
        world = tb.World(gravity=(0, 0, -G))
        robot = tb.load_mjcf(world, path, margins=margins)
        sim = tb.Simulator(world, dt=0.01)
        sim.step(300)
        z = robot.kinematics.qpos()[2]
        assert z == pytest.approx(qpos[2] - offset, abs=1e-3)


@pytest.mark.parametrize("edit, problem", [(("margin=\"0.0\"", "margin=\"-0.01\""), "margin: must be >= 0"),
                                           (("<geom type=\"sphere\"", "<geom condim=\"2\" type=\"sphere\""),
                                            "condim: expected 1, 3, 4 or 6")])
def test_a_bad_margin_or_condim_is_one_line(tmp_path, edit, problem):
    path = _ball(tmp_path, 0.0, 0.0)
    path.write_text(path.read_text().replace(*edit))
    with pytest.raises(InputError) as err:
        tb.load_mjcf(tb.World(), path)
    message = str(err.value)
    assert problem in message and "\n" not in message


def test_a_scene_reads_an_mjcf_robots_margins_and_refuses_them_for_a_urdf(tmp_path):
    """``[[robots]] margins = true`` is ``load_mjcf(margins=True)``; on a URDF, one line naming the key."""
    from tumble.scene import load_scene

    _ball(tmp_path, 0.01, 0.02)
    scene = tmp_path / "scene.toml"
    scene.write_text('[[robots]]\nfile = "ball.xml"\nmargins = true\n')
    world = load_scene(scene).world
    margins = {name.split("/")[-1]: m.margin for name, m in zip(world.names, world.materials)}
    assert margins["ball"] == 0.01 and margins["floor"] == 0.02
    (tmp_path / "arm.urdf").write_text('<robot name="r"><link name="a"/></robot>')
    scene.write_text('[[robots]]\nfile = "arm.urdf"\nmargins = true\n')
    with pytest.raises(InputError) as err:
        load_scene(scene)
    assert "robots[0].margins" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("condim, spinning", [(3, 0.0), (4, 0.02), (6, 0.02)])
def test_a_geoms_condim_and_torsional_friction_are_its_bodys(tmp_path, condim, spinning):
    """A geom's ``condim`` is its body's ``Material.condim`` (MuJoCo's default 3 where unset), and
    its torsional friction (``friction``'s second number, m) its spinning friction from condim 4
    on (MuJoCo's torque limit s N, the same as tumble's); below it MuJoCo ignores the number."""
    path = _ball(tmp_path, 0.0, 0.0)
    text = path.read_text().replace('mass="1"', f'mass="1" condim="{condim}" friction="1 0.02 0.001"')
    path.write_text(text)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    mat = world.materials[robot.links["ball"].index]
    assert mat.condim == condim and mat.spinning_friction == spinning
    floor = world.materials[robot.links["world/floor"].index]
    assert floor.condim == 3 and floor.spinning_friction == 0.0


PAIR = """<mujoco><option timestep="0.0005" cone="elliptic"/>
<worldbody><geom name="floor" type="plane" size="5 5 .1" friction="0.3"/>
<body name="b" pos="0 0 0.05"><freejoint/>
<geom name="box" type="box" size="0.2 0.2 0.05" mass="1" friction="0.7" contype="0" conaffinity="0"/></body>
</worldbody><contact>PAIRS</contact></mujoco>"""


@pytest.mark.parametrize("pairs, mu", [('<pair geom1="floor" geom2="box" friction="0.2 0.2"/>', 0.2),
                                       ('<pair geom1="box" geom2="floor" condim="1"/>', 0.0),
                                       ('<pair geom1="floor" geom2="box"/>', 1.0),  # MuJoCo's default, not the geoms'
                                       ("", None)])
def test_an_explicit_pair_collides_with_its_own_friction_as_in_mujoco(tmp_path, pairs, mu):
    """``<contact><pair>``: a slab (0.4 x 0.4 x 0.1 m: it does not tip at friction 1) whose geom
    touches nothing by its masks (contype = conaffinity = 0) slides on the floor through an explicit pair, at the pair's friction (default 1, MuJoCo's),
    frictionless with the pair's condim 1; without the pair it falls through the floor, in both
    engines. tumble's deceleration to 1e-4 m/s of Coulomb's; MuJoCo's to 10 % (its soft contacts'
    friction falls short of Coulomb's: 0.194 g for 0.2, 0.906 g for 1, measured). The pair is
    ``World.set_pair_material``."""
    path = tmp_path / "pair.xml"
    path.write_text(PAIR.replace("PAIRS", pairs))
    deceleration, qpos = _mujoco_slide(path, 0.05)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    box = robot.links["b"]
    box.v = (2.0, 0.0, 0.0)
    traj = tb.Simulator(world, dt=1 / 240).run(0.1, frame_rate=240)
    if mu is None:
        free_fall = 0.05 - 0.5 * G * 0.1 ** 2  # through the floor, in both
        assert qpos[2] == pytest.approx(free_fall, abs=1e-3) and box.x[2] == pytest.approx(free_fall, abs=1e-3)
        assert not world.pair_materials
        return
    assert deceleration == pytest.approx(mu * G, abs=0.1 * max(mu, 0.2) * G)
    t, vx = traj.time, traj.velocity[:, box.index, 0]
    sliding = (t > 0.02) & (vx > 0.05)
    np.testing.assert_allclose(vx[sliding], 2.0 - mu * G * t[sliding], rtol=0, atol=1e-4)
    assert abs(box.x[2] - 0.05) < 1e-4


@pytest.mark.parametrize("pairs, problem", [
    ('<pair geom1="floor" geom2="lid"/>', "contact.pair[0].geom2: unknown geom 'lid'"),
    ('<pair geom1="floor"/>', "contact.pair[0].geom2: missing"),
    ('<pair name="p" geom1="floor" geom2="box" condim="5"/>', "contact.pair[p].condim: expected 1, 3, 4 or 6"),
    ('<pair geom1="floor" geom2="box" friction="-1"/>', "contact.pair[0].friction: must be >= 0"),
])
def test_bad_pairs_are_one_line(tmp_path, pairs, problem):
    path = tmp_path / "pair.xml"
    path.write_text(PAIR.replace("PAIRS", pairs))
    with pytest.raises(InputError) as err:
        tb.load_mjcf(tb.World(), path)
    assert problem in str(err.value) and "\n" not in str(err.value)
