"""Property-based tests of the URDF reader (hypothesis): a URDF file with any attribute given any
value, any element dropped or repeated, never ends in a traceback: it loads, or it is refused with
one ``InputError`` line naming the file, with each of the three inertia sources, and no warning (and, through a scene file and the CLI, status 2 with
one line). The base file has every element tumble reads (tests/physics/test_urdf.py's arm, a
slider, a mesh, a contact material, damping and friction)."""

import warnings
import xml.etree.ElementTree as ET

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tumble as tb
from tumble.errors import InputError
from tumble.urdf import load_urdf

SETTINGS = dict(deadline=None, database=None, derandomize=True, suppress_health_check=list(HealthCheck))

BASE = """<?xml version="1.0"?>
<robot name="fuzz">
  <link name="world"/>
  <link name="upper">
    <inertial><origin xyz="0.1 0 -0.4" rpy="0.3 0 0"/><mass value="1.5"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.04"/></inertial>
    <collision><origin xyz="0 0 -0.4"/><geometry><box size="0.1 0.1 0.8"/></geometry></collision>
    <contact><lateral_friction value="0.7"/><restitution value="0.1"/></contact>
  </link>
  <link name="lower">
    <inertial><origin xyz="0 0 -0.3"/><mass value="0.7"/><inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.004"/></inertial>
    <collision><origin xyz="0 0 -0.3"/><geometry><cylinder radius="0.04" length="0.6"/></geometry></collision>
    <collision><origin xyz="0 0 -0.6"/><geometry><capsule radius="0.03" length="0.1"/></geometry></collision>
  </link>
  <link name="tip">
    <inertial><mass value="0.4"/><inertia ixx="0.0004" ixy="0" ixz="0" iyy="0.0004" iyz="0" izz="0.0004"/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <link name="cart">
    <inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><geometry><mesh filename="part.stl" scale="1 1 1"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute"><parent link="world"/><child link="upper"/>
    <origin xyz="0 0 2"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/>
    <dynamics damping="0.1" friction="0.01"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.8"/><axis xyz="0 1 0"/></joint>
  <joint name="wrist" type="fixed"><parent link="lower"/><child link="tip"/><origin xyz="0.05 0 -0.6"/></joint>
  <joint name="slide" type="prismatic"><parent link="upper"/><child link="cart"/>
    <origin xyz="0 0.2 -0.2" rpy="0 0.5 0"/><axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1"/>
    <mimic joint="elbow" multiplier="0.05" offset="0.01"/></joint>
</robot>
"""

values = st.one_of(
    st.sampled_from(["", " ", "0", "-1", "1e300", "-1e-300", "nan", "inf", "-inf", "1 2", "1 2 3", "1 2 3 4", "1, 2, 3",
                     "a b c", "world", "upper", "lower", "tip", "cart", "revolute", "continuous", "prismatic", "fixed",
                     "floating", "planar", "spherical", "screw", "package://x/y.stl", "part.stl", "missing.obj",
                     "0 0 0", "1e-20 0 0", "3 -3", "\n", "\x00"]),
    st.text(max_size=12),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


def mutate(data, base: str, new_attributes) -> str:
    """``base`` XML with 1 to 4 random changes: an attribute given a value, a new attribute (one of
    ``new_attributes``), an element dropped or repeated (also the MJCF fuzz's)."""
    root = ET.fromstring(base)
    elements = list(root.iter())
    attributes = [(e.tag, a) for e in elements for a in e.attrib]
    for _ in range(data.draw(st.integers(1, 4))):
        kind = data.draw(st.sampled_from(["attribute", "drop", "repeat", "new attribute"]))
        if kind == "attribute":
            tag, attr = attributes[data.draw(st.integers(0, len(attributes) - 1))]
            candidates = [e for e in elements if e.tag == tag and attr in e.attrib]
            if candidates:
                candidates[data.draw(st.integers(0, len(candidates) - 1))].set(attr, data.draw(values))
        elif kind == "new attribute":
            e = elements[data.draw(st.integers(0, len(elements) - 1))]
            e.set(data.draw(st.sampled_from(new_attributes)), data.draw(values))
        else:
            parent = elements[data.draw(st.integers(0, len(elements) - 1))]
            if len(parent):
                child = parent[data.draw(st.integers(0, len(parent) - 1))]
                if kind == "drop":
                    parent.remove(child)
                else:
                    parent.append(child)
        elements = list(root.iter())
    return ET.tostring(root, encoding="unicode")


def mutated(data) -> str:
    return mutate(data, BASE, ["name", "value", "xyz", "rpy", "size", "radius", "type", "link", "joint", "multiplier",
                               "offset"])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    import trimesh

    path = tmp_path_factory.mktemp("urdf_fuzz")
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(path / "part.stl")
    return path


@settings(max_examples=400, **SETTINGS)
@given(data=st.data())
def test_any_mutation_loads_or_is_one_line(folder, data):
    text = mutated(data)
    path = folder / "r.urdf"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    for inertia in ("file", "balance", "shapes"):
        world = tb.World()
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a warning would be a second line on the terminal
            try:
                load_urdf(world, path, inertia=inertia)
            except InputError as err:
                line = str(err)
                assert "\n" not in line and line.startswith(str(path)), line
                continue
        # loaded: every link has a body and the joints are bound
        assert world.body_count >= 1 and all(j.bound is not None for j in world.joints)


@settings(max_examples=60, **SETTINGS)
@given(data=st.data())
def test_a_bad_robot_in_a_scene_is_status_2_with_one_line(folder, data, capsys):
    from tumble.cli import main

    (folder / "r.urdf").write_text(mutated(data), encoding="utf-8", errors="surrogatepass")
    (folder / "s.toml").write_text('[simulation]\nduration = 0.5\n[[robots]]\nfile = "r.urdf"\n')
    capsys.readouterr()
    status = main(["validate", str(folder / "s.toml")])
    err = capsys.readouterr().err.strip()
    assert status in (0, 2)
    if status == 2:
        assert len(err.splitlines()) == 1 and "robots[0].file: r.urdf: " in err and "Traceback" not in err, err
