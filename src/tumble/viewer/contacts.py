"""The contacts a trajectory may carry, for the viewer's toggles.

A run with ``record_contacts`` (scene ``[simulation] record_contacts``) records
them; the toggles draw whatever the trajectory provides under these optional names
(attributes of the ``Trajectory``, or keys of the ``.npz`` file), and nothing otherwise:

* ``contact_point``: (F, C, 3) world points, m; rows with a non-finite entry are
  padding (frames have different numbers of contacts);
* ``contact_force``: (F, C, 3) world force at the same rows, N (optional);
  drawn as arrows from the point, scaled so that the largest force of the run
  is a quarter of the scene's size;
* ``contact_count``: (F,) number of valid rows per frame (optional; when given,
  only the first ``contact_count[k]`` rows of frame k are used).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

CONTACT_KEYS = ("contact_point", "contact_force", "contact_count")
CONTACT_POINT_COLOR = (255, 40, 40)
CONTACT_FORCE_COLOR = (255, 140, 0)


def contact_arrays(traj, extras) -> dict:
    """The contact arrays of ``traj`` (its attributes, else ``extras``, the keys of its ``.npz``),
    checked for their shapes: ``CONTACT_KEYS`` present, and ``force_max`` (N), the largest force
    of the run, when there are forces. Bad shapes raise ``InputError`` at their key."""
    F = len(traj.time)
    out = {}
    for key in CONTACT_KEYS:
        value = getattr(traj, key, None)
        if value is None:
            value = extras.get(key)
        if value is None:
            continue
        value = np.asarray(value, dtype=float)
        expected_ndim = 1 if key == "contact_count" else 3
        if value.ndim != expected_ndim or value.shape[0] != F or (expected_ndim == 3 and value.shape[2] != 3):
            raise InputError(f"expected shape ({F},{' C, 3' if expected_ndim == 3 else ''}), got {value.shape}", key)
        out[key] = value
    if "contact_force" in out and "contact_point" not in out:
        raise InputError("contact_force needs contact_point (the points the forces act at)", "contact_force")
    if "contact_force" in out and out["contact_force"].shape != out["contact_point"].shape:
        raise InputError(f"expected the shape of contact_point {out['contact_point'].shape}, got {out['contact_force'].shape}",
                         "contact_force")
    if "contact_force" in out:
        f = out["contact_force"]
        mags = np.linalg.norm(np.where(np.isfinite(f), f, 0.0), axis=-1)
        out["force_max"] = float(mags.max()) if mags.size else 0.0
    return out


def contacts_at(contacts: dict, k: int):
    """(points (n, 3), forces (n, 3) or None) of frame k of ``contact_arrays``: the valid rows only."""
    if "contact_point" not in contacts:
        return np.zeros((0, 3)), None
    p = contacts["contact_point"][k]
    f = contacts["contact_force"][k] if "contact_force" in contacts else None
    valid = np.all(np.isfinite(p), axis=1)
    if f is not None:
        valid &= np.all(np.isfinite(f), axis=1)
    if "contact_count" in contacts:
        valid &= np.arange(len(p)) < int(contacts["contact_count"][k])
    return p[valid], (None if f is None else f[valid])
