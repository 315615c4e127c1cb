"""Pair routines ``collide_<a>_<b>`` (a <= b in SHAPE_* order), one module per family.

sphere.py, capsule.py, box.py, box_box.py: closed forms and SAT for plane, sphere, capsule, box.
convex.py (with gjk.py): every other pair of sphere, capsule, cylinder, cone, box and
convex hull. plane.py: the plane against cylinder, cone and hull. mesh.py: sphere ...
convex against a static triangle mesh.

Every routine has the same array contract (all world frame, metres)::

    count = collide_a_b(pos_a (3,), rot_a (3, 3), params_a (4,),
                        pos_b (3,), rot_b (3, 3), params_b (4,), speculative,
                        # outputs
                        normal (3,), point (4, 3), separation (4,), feature (4,) int64)

Routines that read hull or mesh data (``convex.py``, ``plane.py``, ``mesh.py``) also take, before the
outputs, ``geometry`` (``ShapeTable.geometry``: the flat hull / mesh arrays) and the
shape rows a, b. ``narrowphase.collide_shapes`` passes them to every routine that needs them.

``normal`` is unit, from a to b, shared by the manifold's points (except against a triangle mesh:
``collide_convex_mesh`` also writes each point's own normal, ``point_normal`` (4, 3)); ``point[k]`` is
midway between the two surfaces; ``separation[k]`` < 0 is penetration; points are
produced only while separation < ``speculative``; ``feature[k]`` is a key local to
the pair that stays the same while the same features touch (warm starting).

NOTE: Numba's on-disk cache (``cache=True``) does not notice when a callee in another
module changes: after editing a routine here, delete ``collision/**/__pycache__/*.nb[ci]``
or ``narrowphase.collide_shapes`` keeps running the old code.

PERF: the box routines allocate a few small arrays per call (about 0.5 us per box-box
pair in a dense pile); scratch buffers passed in by the kernel would remove that.
"""
