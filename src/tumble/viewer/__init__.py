"""The interactive browser viewer (viser): ``view(traj_or_path)``, ``tumble view``.

Needs the ``viewer`` extra (``pip install tumble[viewer]``); importing this
package does not import viser, ``view()`` does.
"""

from .app import Viewer, load_input, view

__all__ = ["Viewer", "load_input", "view"]
