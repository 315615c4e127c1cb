"""Export a trajectory to other tools: glTF 2.0 binary (.glb), USD (.usd, .usda, .usdc) and a
self-contained web page (.html: the glTF and a viewer, ``export.html``).

``export_gltf(traj, path)``, ``export_usd(traj, path)`` and ``export_html(traj, path)``;
``export(traj, path)`` picks the format by the file's suffix. Both write each body's visual mesh
(``tumble.export.meshes``) in its body frame and animate one transform per body:
translation = the centre of mass (``traj.position``), rotation =
``traj.orientation``. USD export needs ``usd-core`` (``pip install tumble[export]``);
glTF export needs nothing beyond NumPy and trimesh.
"""

from __future__ import annotations

from pathlib import Path

GLTF_SUFFIXES = (".glb",)
USD_SUFFIXES = (".usd", ".usda", ".usdc")
HTML_SUFFIXES = (".html", ".htm")
SUFFIXES = GLTF_SUFFIXES + USD_SUFFIXES + HTML_SUFFIXES


def export_gltf(traj, path) -> Path:
    """Write ``traj`` as binary glTF 2.0 (.glb); see ``tumble.export.gltf``."""
    from .gltf import export_gltf as _export

    return _export(traj, path)


def export_usd(traj, path) -> Path:
    """Write ``traj`` as a USD stage (.usd, .usda, .usdc); see ``tumble.export.usd``."""
    from .usd import export_usd as _export

    return _export(traj, path)


def export_html(traj, path, title=None) -> Path:
    """Write ``traj`` as one self-contained web page (.html); see ``tumble.export.html``."""
    from .html import export_html as _export

    return _export(traj, path, title)


def export(traj, path) -> Path:
    """Write ``traj`` in the format named by ``path``'s suffix (.glb, .usd, .usda, .usdc, .html)."""
    suffix = Path(path).suffix.lower()
    if suffix in GLTF_SUFFIXES:
        return export_gltf(traj, path)
    if suffix in USD_SUFFIXES:
        return export_usd(traj, path)
    if suffix in HTML_SUFFIXES:
        return export_html(traj, path)
    raise ValueError(f"unknown export format {Path(path).suffix or '(no suffix)'!r} (expected {', '.join(SUFFIXES)})")


__all__ = ["SUFFIXES", "export", "export_gltf", "export_html", "export_usd"]
