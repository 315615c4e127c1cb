"""See a run: headless video (``render_video``, ``render_frame``) and plots (``plot_trajectory``).

Needs the ``render`` extra (pyvista, matplotlib, imageio, imageio-ffmpeg);
the submodules import those only when called, so ``import tumble.render`` is cheap.
"""

from __future__ import annotations

__all__ = ["Camera", "body_colors", "camera_at", "plot_trajectory", "render_frame", "render_video"]


def __getattr__(name):
    if name in ("render_video", "render_frame", "camera_at", "Camera", "body_colors"):
        from . import video

        return getattr(video, name)
    if name == "plot_trajectory":
        from .plots import plot_trajectory

        return plot_trajectory
    raise AttributeError(f"module 'tumble.render' has no attribute {name!r}")
