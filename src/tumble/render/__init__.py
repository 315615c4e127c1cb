"""See a run: headless video (``render_video``, ``render_frame``) and plots (``plot_trajectory``).

Needs the ``render`` extra (pyvista, matplotlib, imageio, imageio-ffmpeg);
the submodules import those only when called, so ``import tumble.render`` is cheap.
"""

from __future__ import annotations

__all__ = ["render_video", "render_frame", "camera_at", "Camera", "body_colors", "plot_trajectory"]


def __getattr__(name):
    if name in ("render_video", "render_frame", "camera_at", "Camera", "body_colors"):
        from . import video

        return getattr(video, name)
    if name == "plot_trajectory":
        from .plots import plot_trajectory

        return plot_trajectory
    raise AttributeError(f"module 'tumble.render' has no attribute {name!r}")
