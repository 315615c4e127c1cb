"""MJCF height fields: ``<asset><hfield>`` read into tumble's terrain (``shapes.heightfield``).

What MuJoCo's compiler makes of a height field (XML reference, ``hfield``; each rule below was
measured on MuJoCo's own compiled model, ``MjModel.hfield_data``, and is checked against it in
``tests/physics/test_mjcf.py``):

- ``size = "rx ry top base"``: the grid spans [-rx, rx] x [-ry, ry] in the geom's frame, the surface
  is ``top`` times the normalised elevation, and the solid's flat bottom is at z = -``base``.
- The elevation, from ``elevation`` (``nrow`` x ``ncol`` numbers), a PNG file or MuJoCo's binary
  file (int32 nrow, int32 ncol, then nrow x ncol float32), is normalised to [0, 1] by its minimum
  and maximum (all zero when they are equal or when there is no data), and kept in float32.
- Row order: ``elevation``'s first row and a PNG's top row are at y = +ry (as an image is seen
  from above); a binary file's first row is at y = -ry.
- A PNG's grey value is its first channel (a colour image's red), a 16-bit image's high byte.
- Each grid cell is two triangles split along the diagonal from (row i, column j) to (i + 1,
  j + 1), rows along y, columns along x: ``shapes.heightfield``'s split.

tumble's height fields are static: an ``hfield`` geom must be a ``<worldbody>`` geom (MuJoCo also
lets one ride a moving body).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import checks
from .errors import InputError
from .mjcf_control import floats, whole_number

HFIELD_SIZE_NUMBERS = 4  # rx ry top base


def read_hfields(reader, root) -> dict:
    """{name: (heights (nrow, ncol) m, size (2,) m full extents, base m)} of the file's
    ``<asset><hfield>`` elements; ``reader.meshdir``: the folder of their files (MuJoCo's
    ``meshdir``, which also serves height fields). InputError (one line) for a bad one."""
    out = {}
    for asset in root.findall("asset"):
        for k, element in enumerate(asset.findall("hfield")):
            a = element.attrib
            file = a.get("file")
            name = a.get("name") or (Path(file).stem if file else None)
            key = f"asset.hfield[{name if name else k}]"
            if not name:
                raise InputError("a height field needs a name (or a file)", key)
            if name in out:
                raise InputError("duplicate height field name", key)
            if "size" not in a:
                raise InputError("missing size (rx ry top base)", key)
            rx, ry, top, base = floats(a["size"], f"{key}.size", (HFIELD_SIZE_NUMBERS,))
            if min(rx, ry, top, base) <= 0.0:
                raise InputError(f"expected four numbers > 0, got {a['size']!r}", f"{key}.size")
            if file:
                if "elevation" in a:
                    raise InputError("give a file or elevation, not both", f"{key}.elevation")
                data = _file_data(reader, file, key)
            else:
                data = _attribute_data(a, key)
            out[name] = (top * _normalised(data), np.array([2.0 * rx, 2.0 * ry]), float(base))
    return out


def _attribute_data(a: dict, key: str) -> np.ndarray:
    """(nrow, ncol) of ``nrow``, ``ncol`` and ``elevation`` (its first row at +y: flipped here);
    zeros without ``elevation`` (MuJoCo's: the data are set at run time)."""
    shape = []
    for attr in ("nrow", "ncol"):
        if a.get(attr) is None:
            raise InputError(f"missing {attr} (or a file)", key)
        shape.append(whole_number(a[attr], f"{key}.{attr}", 2))
    checks.check_memory(8 * shape[0] * shape[1], "a height field's grid", key)
    if "elevation" not in a:
        return np.zeros(shape)
    values = floats(a["elevation"], f"{key}.elevation", (shape[0] * shape[1],))
    return values.reshape(shape)[::-1]


def _file_data(reader, file: str, key: str) -> np.ndarray:
    """(nrow, ncol) from a PNG or MuJoCo's binary height field file, row 0 at -y."""
    path = reader.meshdir / file
    if not path.is_file():
        raise InputError(f"height field file not found: {path}", f"{key}.file")
    checks.check_memory(path.stat().st_size * checks.FILE_EXPANSION, f"reading the height field file {path}", key,
                        str(reader.path))
    if path.suffix.lower() == ".png":
        return _png_data(path, key)
    raw = path.read_bytes()
    if len(raw) < 8:
        raise InputError(f"{path.name}: not a PNG and too short for MuJoCo's binary height field", f"{key}.file")
    nrow, ncol = (int(v) for v in np.frombuffer(raw[:8], dtype="<i4"))
    if nrow < 2 or ncol < 2 or len(raw) != 8 + 4 * nrow * ncol:
        raise InputError(f"{path.name}: expected int32 nrow, ncol (>= 2) and nrow x ncol float32 heights "
                         f"(MuJoCo's binary height field)", f"{key}.file")
    data = np.frombuffer(raw[8:], dtype="<f4").reshape(nrow, ncol).astype(float)
    if not np.all(np.isfinite(data)):
        raise InputError(f"{path.name}: heights must be finite numbers", f"{key}.file")
    return data


def _png_data(path: Path, key: str) -> np.ndarray:
    """(nrow, ncol) grey values of a PNG (first channel, 8-bit), its top row last (at +y)."""
    try:
        from PIL import Image
    except ImportError:
        raise InputError("reading a PNG height field needs Pillow (pip install pillow, or tumble[render])",
                         f"{key}.file") from None
    try:
        with Image.open(path) as image:
            mode = image.mode
            if mode == "P":
                image = image.convert("RGB")
                mode = "RGB"
            pixels = np.asarray(image)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path.name}: cannot read the image ({exc})", f"{key}.file") from None
    if pixels.ndim == 3:
        pixels = pixels[:, :, 0]
    if mode.startswith("I;16") or mode == "I":
        pixels = np.asarray(pixels, dtype=np.int64) >> 8  # MuJoCo reads 16-bit PNGs at 8 bits (measured)
    elif pixels.dtype == bool:
        pixels = pixels * 255
    if pixels.ndim != 2 or pixels.shape[0] < 2 or pixels.shape[1] < 2:
        raise InputError(f"{path.name}: expected an image of at least 2 x 2 pixels", f"{key}.file")
    return np.asarray(pixels, dtype=float)[::-1]


def _normalised(data: np.ndarray) -> np.ndarray:
    """(v - min) / (max - min) in float32 arithmetic on float32 data, as MuJoCo's compiler
    computes and stores it (the same bits as its ``hfield_data``); zeros if max == min."""
    d = np.asarray(data, dtype=np.float32)
    lo, hi = d.min(), d.max()
    if not hi > lo:
        return np.zeros(d.shape)
    return ((d - lo) / (hi - lo)).astype(float)
