"""Property-based tests of the MJCF reader (hypothesis), as tests/test_urdf_fuzz.py for URDF: an MJCF
file with any attribute given any value, any element dropped or repeated, never ends in a traceback:
it loads and steps, or it is refused with one ``InputError`` line naming the file, and no warning.
The base file has every element tumble reads (default classes, every orientation form, fromto, a
mesh asset, each joint type, several joints in one body, an inertial, actuators, an exclude, an
include, sites, fixed and tracking cameras, fixed tendons with a motor and a servo, a joint equality, sensors, a
keyframe)."""

import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tumble as tb
from tumble.errors import InputError

from .test_urdf_fuzz import SETTINGS, mutate

BASE = """<mujoco model="fuzz">
  <compiler angle="degree" eulerseq="xyz" autolimits="true"/>
  <default>
    <joint damping="0.1"/>
    <geom density="900" friction="0.8"/>
    <default class="big"><geom type="box" size="0.05 0.04 0.03"/><joint stiffness="2" springref="5"/></default>
  </default>
  <asset><mesh name="part" file="part.stl" scale="1 1 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="step" type="box" size="0.5 0.5 0.05" pos="2 0 0"/>
    <body name="a" pos="0 0 2" euler="10 20 30" childclass="big">
      <joint name="j1" type="hinge" axis="0 1 0" range="-90 90" frictionloss="0.01"/>
      <geom pos="0.1 0 -0.2" quat="1 0 0 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.03"/>
      <site name="s_a" type="box" size="0.05 0.05 0.05" pos="0 0 -0.1"/>
      <camera name="cam_a" pos="0 -1 0" xyaxes="1 0 0 0 0 1" fovy="50" resolution="32 24"/>
      <camera name="cam_track" mode="trackcom" pos="0 -2 0.5"/>
      <body name="b" pos="0 0 -0.5" axisangle="1 0 0 30">
        <joint name="j2" type="slide" axis="1 0 0" range="-0.1 0.1"/>
        <joint name="j2b" type="hinge" axis="0 0 1" pos="0 0 0.01"/>
        <inertial pos="0 0 -0.1" mass="0.5" diaginertia="0.01 0.01 0.01" xyaxes="1 0 0 0 1 0"/>
        <geom type="cylinder" size="0.03 0.1" zaxis="0 1 1"/>
        <body name="c" pos="0 0 -0.3">
          <joint name="j3" type="ball" range="0 45" damping="0" stiffness="0"/>
          <geom type="mesh" mesh="part"/>
        </body>
      </body>
    </body>
    <body name="ball" pos="1 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/><site name="s_ball"/></body>
    <include file="inc.xml"/>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j1" coef="1"/><joint joint="j2" coef="-0.5"/></fixed>
    <fixed name="tied"><joint joint="j2" coef="0.5"/></fixed></tendon>
  <equality><joint joint1="j2b" joint2="j1" polycoef="0 0.5 0.1"/></equality>
  <sensor>
    <jointpos joint="j1"/><jointvel joint="j2"/><framepos objtype="site" objname="s_a"/>
    <framequat objtype="xbody" objname="b"/><gyro site="s_a"/><velocimeter site="s_ball"/>
    <rangefinder site="s_a"/><touch site="s_ball"/><force site="s_a"/><torque site="s_a"/>
    <subtreecom body="a"/><clock/><accelerometer site="s_a"/><actuatorfrc actuator="servo"/>
    <jointactuatorfrc joint="j2"/><tendonpos tendon="t"/>
  </sensor>
  <keyframe><key name="home" qpos="0.1 0.02 0.3 1 0 0 0 1 0 1 1 0 0 0" qvel="0 0 0 0 0 0 0 0 0 0 0 0"/></keyframe>
  <contact><exclude body1="a" body2="c"/></contact>
  <actuator><position joint="j1" kp="10" kv="1" forcerange="-5 5"/><motor joint="j2"/>
    <motor name="pull" tendon="t" gear="2"/><position name="servo" tendon="tied" kp="3" dampratio="1"/></actuator>
</mujoco>
"""


def mutated(data) -> str:
    return mutate(data, BASE, ["name", "pos", "quat", "euler", "size", "type", "class", "range", "fromto", "mass",
                               "axis", "joint", "limited", "zaxis", "site", "objtype", "objname", "coef", "qpos",
                               "qvel", "tendon", "actuator", "mode", "fovy", "resolution", "body", "file", "joint1", "joint2",
                               "polycoef", "dampratio"])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    import trimesh

    path = tmp_path_factory.mktemp("mjcf_fuzz")
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(path / "part.stl")
    (path / "inc.xml").write_text('<mujoco><body name="inc" pos="0 1 0.5"><geom type="box" size="0.1 0.1 0.1"/>'
                                  '</body></mujoco>')
    return path


def test_the_base_file_loads(folder):
    (folder / "m.xml").write_text(BASE)
    world = tb.World()
    robot = tb.load_mjcf(world, folder / "m.xml", keyframe="home")
    assert set(robot.joints) == {"j1", "j2", "j2b", "j3"} and world.exact_joints
    assert "inc" in robot.links and set(robot.sites) == {"s_a", "s_ball"} and set(robot.cameras) == {"cam_a", "cam_track"}
    assert len(robot.sensors) == 15 and robot.sensors_left_off == ["sensor12"] and "pull" in robot.actuators
    assert set(robot.sensor_data()) == set(robot.sensors)
    assert robot.actuators["servo"].joint == "j2" and robot.actuators["servo"].gear == 0.5
    assert robot.actuators["servo"].bias[2] < 0.0  # its dampratio made a kv
    assert robot.kinematics.qpos()[0] == pytest.approx(0.1)


@settings(max_examples=300, **SETTINGS)
@given(data=st.data())
def test_any_mutation_loads_or_is_one_line(folder, data):
    path = folder / "m.xml"
    path.write_text(mutated(data), encoding="utf-8", errors="surrogatepass")
    world = tb.World()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning would be a second line on the terminal
        try:
            tb.load_mjcf(world, path)
        except InputError as err:
            line = str(err)
            assert "\n" not in line and line.startswith(str(path)), line
            return
    assert world.body_count >= 1 and all(j.bound is not None for j in world.joints)


@settings(max_examples=40, **SETTINGS)
@given(data=st.data())
def test_a_bad_model_in_a_scene_is_status_2_with_one_line(folder, data, capsys):
    from tumble.cli import main

    (folder / "m.xml").write_text(mutated(data), encoding="utf-8", errors="surrogatepass")
    (folder / "s.toml").write_text('[simulation]\nduration = 0.5\n[[robots]]\nfile = "m.xml"\n')
    capsys.readouterr()
    status = main(["validate", str(folder / "s.toml")])
    err = capsys.readouterr().err.strip()
    assert status in (0, 2)
    if status == 2:
        assert len(err.splitlines()) == 1 and "robots[0].file: m.xml: " in err and "Traceback" not in err, err
