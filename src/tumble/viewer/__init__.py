"""The interactive browser viewer (viser): ``view(traj_or_path)``, ``tumble view``; and the
live viewer, a scene simulated as it is watched and poked: ``live(scene)``, ``tumble view
SCENE --live``.

Needs the ``viewer`` extra (``pip install tumble[viewer]``); importing this
package does not import viser, ``view()`` and ``live()`` do.
"""

from .app import Viewer, load_input, view
from .live_viewer import LiveViewer, live

__all__ = ["LiveViewer", "Viewer", "live", "load_input", "view"]
