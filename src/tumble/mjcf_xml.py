"""An MJCF file's XML as MuJoCo's parser sees it: ``<include>`` elements expanded and the top-level
sections it may repeat merged.

MuJoCo's rule (XML reference, ``include``): an ``<include file="..."/>`` may stand anywhere in the
tree; it is replaced by the children of the top ``<mujoco>`` element of the file it names, whose
path is taken from the directory of the main model file; includes nest, and a file included twice
is an error (which also stops a cycle). The layout of MuJoCo Menagerie's models: ``scene.xml``
(floor, lights) includes the robot's file. After the expansion a model can hold several
``<worldbody>`` and ``<compiler>`` sections: the worldbodies' children are joined in file order
into the first, and the compilers' attributes too (a later one's win), as MuJoCo reads them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from .errors import InputError
from .urdf_read import read_xml

MAX_INCLUDED_FILES = 256


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
