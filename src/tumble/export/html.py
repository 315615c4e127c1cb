"""A run as one self-contained web page: ``export_html(traj, path)``, ``tumble export RUN -o run.html``,
and ``Trajectory.show()`` in a Jupyter notebook.

The page holds the run's glTF binary (``export.gltf``: the same bytes ``export_gltf`` writes,
base64 in a ``<script type="application/octet-stream">``) and Google's ``<model-viewer>`` web
component (three.js inside; vendored in ``export/static``, Apache-2.0, its licence beside it),
so it opens from a file, an e-mail or a notebook with no network and no server (Brax's
``io.html.render`` is the model: a static viewer filled with the run). Under the model: play and
pause, a time slider, the clock and a speed choice; drag to turn the camera, scroll to zoom.
A body disabled at some frames (``World.set_enabled``) vanishes there: the glTF's scale channel
(0 there, STEP), which model-viewer plays as it plays the poses.

Page size: the glTF's bytes times 4/3 plus the viewer's 1.07 MB.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

STATIC = Path(__file__).resolve().parent / "static"
VIEWER_JS = STATIC / "model-viewer-umd.min.js"  # @google/model-viewer 4.4.0, dist/model-viewer-umd.min.js
SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0)

_PAGE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="tumble">
<title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; font: 14px system-ui, sans-serif; background: #f5f5f5; color: #222; }}
#view {{ display: flex; flex-direction: column; height: 100%; }}
model-viewer {{ flex: 1; width: 100%; min-height: 200px; background: linear-gradient(#fdfdfd, #dcdfe4); }}
#bar {{ display: flex; gap: 10px; align-items: center; padding: 6px 10px; }}
#time {{ flex: 1; }}
#clock {{ font-variant-numeric: tabular-nums; min-width: 6em; text-align: right; }}
#info {{ color: #666; }}
</style>
<script>{viewer_js}</script>
</head>
<body>
<div id="view">
<model-viewer id="model" camera-controls shadow-intensity="1" interaction-prompt="none" autoplay
  camera-target="{target}" camera-orbit="{orbit}" min-camera-orbit="auto auto 0.001m" alt="{title}"></model-viewer>
<div id="bar">
<button id="play" type="button">Pause</button>
<input id="time" type="range" min="0" max="{duration}" step="any" value="0" aria-label="time (s)">
<span id="clock">0.000 s</span>
<label>speed <select id="speed">{speeds}</select></label>
<span id="info">{info}</span>
</div>
</div>
<script id="tumble-glb" type="application/octet-stream">{glb}</script>
<script>
(function () {{
  const model = document.getElementById("model");
  const slider = document.getElementById("time");
  const clock = document.getElementById("clock");
  const play = document.getElementById("play");
  const text = document.getElementById("tumble-glb").textContent.trim();
  const raw = atob(text);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  model.src = URL.createObjectURL(new Blob([bytes], {{ type: "model/gltf-binary" }}));
  function show() {{
    slider.value = model.currentTime;
    clock.textContent = model.currentTime.toFixed(3) + " s";
    play.textContent = model.paused ? "Play" : "Pause";
  }}
  model.addEventListener("load", function () {{
    slider.max = model.duration;
    model.play();
    document.body.dataset.ready = "1";
    show();
  }});
  model.addEventListener("error", function (e) {{ document.body.dataset.error = String(e.detail && e.detail.type); }});
  play.addEventListener("click", function () {{ if (model.paused) model.play(); else model.pause(); show(); }});
  slider.addEventListener("input", function () {{ model.pause(); model.currentTime = Number(slider.value); show(); }});
  document.getElementById("speed").addEventListener("change", function (e) {{ model.timeScale = Number(e.target.value); }});
  (function tick() {{ show(); requestAnimationFrame(tick); }})();
}})();
</script>
</body>
</html>
"""


def html_document(traj, title: str | None = None) -> str:
    """The page (str) showing ``traj`` (a ``Trajectory`` with at least one frame): its glTF
    binary (``gltf.gltf_document``) and the viewer, inline. ``title``: the page's title
    (default: tumble, the body and frame counts and the duration)."""
    from .gltf import glb_bytes, gltf_document

    glb = glb_bytes(*gltf_document(traj))
    n, frames = len(traj.names), len(traj.time)
    duration = float(traj.time[-1] - traj.time[0]) if frames else 0.0
    info = f"{n} {'body' if n == 1 else 'bodies'}, {frames} frames, {duration:.3f} s"
    js = VIEWER_JS.read_text(encoding="utf-8").replace("</script", "<\\/script")  # (none today; kept safe)
    speeds = "".join(f'<option value="{s:g}"{" selected" if s == 1.0 else ""}>{s:g}x</option>' for s in SPEEDS)
    target, distance = camera_view(traj)
    return _PAGE.format(title=html.escape(title or f"tumble: {info}"), viewer_js=js, duration=json.dumps(duration),
                        speeds=speeds, info=html.escape(info), glb=base64.b64encode(glb).decode("ascii"),
                        target=" ".join(f"{v:.6g}m" for v in target), orbit=f"30deg 65deg {distance:.6g}m")


def camera_view(traj) -> tuple:
    """(target (3,) m in glTF's frame (y up: tumble's (x, z, -y)), distance m) of a camera that
    sees where the moving bodies go over the run: the middle of the box their centres sweep,
    from 2.5 times its half diagonal (at least 0.5 m for the bodies' own size). Fixed bodies
    (a ground plane is drawn as a wide square) are left out of the framing, as long as
    something moves, and so are the frames where a body is disabled (hidden: a body waiting
    out of sight to appear is framed where it is seen)."""
    import numpy as np

    from .meshes import enabled_flags

    position = np.asarray(traj.position, dtype=float)
    moving = np.ones(position.shape[1], dtype=bool) if traj.fixed is None else ~np.asarray(traj.fixed, dtype=bool)
    if not moving.any():
        moving[:] = True
    shown = enabled_flags(traj)[:, moving]
    # (all frames when the moving bodies are never shown: something is framed)
    points = position[:, moving][shown] if shown.any() else position[:, moving].reshape(-1, 3)
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo + hi)
    half = max(0.5 * float(np.linalg.norm(hi - lo)), 0.5)
    return (centre[0], centre[2], -centre[1]), 2.5 * half


def export_html(traj, path, title: str | None = None) -> Path:
    """Write ``traj`` as one self-contained web page (.html) at ``path``, atomically; returns the path."""
    return _write_page(html_document(traj, title), path)


def _write_page(page: str, path) -> Path:
    from ..trajectory import write_atomic

    data = page.encode("utf-8")
    return write_atomic(path, lambda fh: fh.write(data))


class HtmlView:
    """A run shown in a notebook cell (``Trajectory.show()``): Jupyter calls ``_repr_html_``, an
    ``<iframe>`` whose ``srcdoc`` is the page of ``html_document`` (scripts run in the frame alone)."""

    def __init__(self, traj, height: int = 480, title: str | None = None):
        self.page = html_document(traj, title)
        self.height = int(height)

    def _repr_html_(self) -> str:
        return (f'<iframe srcdoc="{html.escape(self.page, quote=True)}" sandbox="allow-scripts" '
                f'style="width: 100%; height: {self.height}px; border: 0;"></iframe>')

    def save(self, path) -> Path:
        """Write the page to ``path`` (atomically)."""
        return _write_page(self.page, path)
