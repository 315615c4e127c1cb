"""An MJCF file's XML as MuJoCo's parser sees it: ``<include>`` elements expanded and the top-level
sections it may repeat merged.

MuJoCo's rule (XML reference, ``include``): an ``<include file="..."/>`` may stand anywhere in the
tree; it is replaced by the children of the top ``<mujoco>`` element of the file it names, whose
path is taken from the directory of the main model file; includes nest, and a file included twice
is an error (which also stops a cycle). The layout of MuJoCo Menagerie's models: ``scene.xml``
(floor, lights) includes the robot's file. After the expansion a model can hold several
``<worldbody>`` and ``<compiler>`` sections: the worldbodies' children are joined in file order
into the first, and the compilers' attributes too (a later one's win), as MuJoCo reads them.

``<frame>`` (XML reference, ``frame``): a pose (``pos`` and one orientation) and a ``childclass``
for the bodies, geoms, joints, sites, cameras and frames it holds, which MuJoCo places in the
frame's pose within the body that holds the frame; it makes no body of its own. ``framed`` walks an
element's children and those inside its frames, and gives each its frame's pose and class.

``<replicate count offset euler sep>`` (XML reference, ``replicate``; each rule measured on
MuJoCo's compiled model): ``count`` copies of its children, copy i in the pose T^i of the
transform T = (``offset``, ``euler`` in the compiler's angle unit and sequence), each named
element's name suffixed by ``sep`` (default none) and i zero-padded to the digits of ``count``
(count 12: 00 ... 11); nested ones expand inside first, so the inner suffix comes first.
``expand_replicates`` writes each copy as a ``<frame>`` in its place.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .errors import InputError
from .urdf_read import read_xml

MAX_INCLUDED_FILES = 256
# elements of <worldbody>/<body> that make bodies or geoms of their own: refused, not dropped without a word
GENERATORS = ("composite", "flexcomp", "attach")


def check_tag(child: ET.Element, where: str):
    """InputError for a generator element (``GENERATORS``): tumble does not expand them."""
    if child.tag in GENERATORS:
        raise InputError(f"<{child.tag}> is not supported (write its bodies and geoms out)", f"{where}.{child.tag}")


def framed(reader, element: ET.Element, tags: tuple, cls: str, key: str):
    """Yield (child, default class, frame) for each child of ``element`` whose tag is in ``tags``,
    and for each such child of its ``<frame>`` elements (nested ones too), in the file's order.

    ``frame`` is None for a direct child, else (position (3,), R (3, 3)): the pose of the frame the
    child sits in, in ``element``'s frame (the frames' poses composed, outermost first); place the
    child with ``place``. The class is ``cls``, or the nearest enclosing frame's ``childclass``.
    ``reader`` reads poses (``reader.pose``: the compiler's angle unit and Euler sequence) and knows
    the default classes (``reader.classes``). Generators inside frames are refused (``check_tag``).
    """
    def walk(parent, cls, frame, where):
        for k, child in enumerate(parent):
            if child.tag in tags:
                yield child, cls, frame
            elif child.tag == "frame":
                fkey = f"{where}.frame[{child.get('name') or k}]"
                fcls = child.get("childclass", cls)
                if fcls not in reader.classes:
                    raise InputError(f"unknown default class {fcls!r}", f"{fkey}.childclass")
                for inner in child:
                    check_tag(inner, fkey)
                yield from walk(child, fcls, place(frame, *reader.pose(child.attrib, fkey)), fkey)

    yield from walk(element, cls, None, key)


def place(frame, position, R) -> tuple:
    """(position (3,), R (3, 3)) of a pose given in ``frame`` (None: already in the parent's frame,
    returned as it is; else (position (3,), R (3, 3)) of the frame in the parent's)."""
    if frame is None:
        return position, R
    return frame[0] + frame[1] @ position, frame[1] @ R


def read_model_xml(path: Path) -> ET.Element:
    """The ``<mujoco>`` root of the MJCF file ``path``, its includes expanded and its repeated
    worldbody and compiler sections merged. InputError (one line, keyed ``include[FILE]``) for a
    missing, unreadable or repeated included file."""
    path = Path(path)
    root = read_xml(path, "MJCF", "mujoco")
    seen = {path.resolve()}
    _expand(root, path.parent, seen)
    _merge(root, "worldbody", children=True)
    _merge(root, "compiler", children=False)
    return root


def _expand(element: ET.Element, base: Path, seen: set):
    """Replace each ``<include>`` below ``element`` by the included file's top-level children
    (themselves expanded), keeping their place among the siblings."""
    k = 0
    while k < len(element):
        child = element[k]
        if child.tag != "include":
            _expand(child, base, seen)
            k += 1
            continue
        name = child.get("file")
        key = f"include[{name}]"
        if not name:
            raise InputError("an <include> needs a file attribute", "include")
        target = (base / name).resolve()
        if target in seen:
            raise InputError("this file is included twice (MuJoCo refuses a repeated include)", key)
        if len(seen) >= MAX_INCLUDED_FILES:
            raise InputError(f"more than {MAX_INCLUDED_FILES} included files", key)
        seen.add(target)
        try:
            included = read_xml(target, "MJCF", "mujoco")
        except InputError as err:
            raise InputError(f"{err.problem} ({target})", key) from None
        _expand(included, base, seen)
        element.remove(child)
        for j, part in enumerate(list(included)):
            element.insert(k + j, part)
        k += len(included)


def _merge(root: ET.Element, tag: str, children: bool):
    """Join the repeated top-level ``tag`` sections into the first: their children (``children``) or
    their attributes (a later section's win)."""
    sections = root.findall(tag)
    for extra in sections[1:]:
        if children:
            sections[0].extend(list(extra))
        else:
            sections[0].attrib.update(extra.attrib)
        root.remove(extra)


MAX_REPLICATED = 100_000  # elements a file's replicates may make (a typo in count stops with one line)


def expand_replicates(root: ET.Element, reader) -> None:
    """Replace each ``<replicate>`` below ``root``'s ``<worldbody>`` by its copies, each a
    ``<frame>`` in the copy's pose (module docstring). ``reader.orientation`` turns ``euler``
    into a rotation (the compiler's angle unit and sequence). InputError (one line) for a bad
    count, offset or euler."""
    from .math3d import matrix_to_quat
    from .mjcf_control import floats, whole_number

    made = [0]

    def expand(parent: ET.Element, where: str):
        k = 0
        while k < len(parent):
            child = parent[k]
            key = f"{where}.{child.tag}[{child.get('name') or k}]"
            expand(child, key)  # inside first: an inner replicate's suffix comes first
            if child.tag != "replicate":
                k += 1
                continue
            count = whole_number(child.get("count", ""), f"{key}.count", 1)
            made[0] += count * sum(1 for _ in child.iter())
            if made[0] > MAX_REPLICATED:
                raise InputError(f"the replicates make more than {MAX_REPLICATED} elements", f"{key}.count")
            offset = floats(child.get("offset", "0 0 0"), f"{key}.offset", (3,))
            R = reader.orientation({"euler": child.get("euler")} if "euler" in child.attrib else {}, key)
            sep = child.get("sep", "")
            width = len(str(count))
            position, turn = np.zeros(3), np.eye(3)
            copies = []
            for i in range(count):
                frame = ET.Element("frame", {"pos": " ".join(repr(float(v)) for v in position),
                                             "quat": " ".join(repr(float(v)) for v in matrix_to_quat(turn))})
                suffix = f"{sep}{i:0{width}d}"
                for part in child:
                    part = copy.deepcopy(part)
                    for element in part.iter():
                        if element.get("name"):
                            element.set("name", element.get("name") + suffix)
                    frame.append(part)
                copies.append(frame)
                position, turn = position + turn @ offset, turn @ R
            parent.remove(child)
            for j, frame in enumerate(copies):
                parent.insert(k + j, frame)
            k += len(copies)

    for worldbody in root.findall("worldbody"):
        expand(worldbody, "worldbody")
