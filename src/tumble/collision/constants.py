"""Collision tolerances, in metres (Box2D v3 / Box3D defaults, /work/shared/BENCHMARKS.md), and
the contact feature-id bases.

NOTE: STYLE 5.1 puts tolerances in ``tumble/constants.py``; they live here until
that module exists (this package may only add files under ``collision/``).
"""

# Penetration the solver leaves alone so that resting contacts do not chatter.
# In metres. Box2D/Box3D: 0.005 (half a centimetre). @warning scaled for objects of
# 0.1 - 10 m; a scene of millimetre parts needs a smaller slop.
LINEAR_SLOP = 0.005

# Contacts are produced while the separation is below this (speculative contacts,
# Catto GDC 2014 "Physics for Game Programmers: Continuous Collision"), and shape
# AABBs are grown by it. In metres. Box3D: 4 * LINEAR_SLOP = 0.02. @warning a larger
# value finds more pairs and contacts; a smaller one lets fast bodies tunnel.
SPECULATIVE_DISTANCE = 4.0 * LINEAR_SLOP

# Overlap beyond which a contact's anchors move towards each body's own surface (solver.contact,
# ``prepare_contacts_kernel``). In metres. Shallower contacts keep Box2D's single anchor point
# (the midpoint of the two surfaces); a body placed or pushed deep into another (a box 100 m under
# a plane) would carry an anchor |s|/2 from its surface, which swings with the body and blew the
# box up. Surface anchors for every contact over 5 cm made the 1000-box pile gain energy between
# two frames (26 mJ of 22 563 J; over 0 m: 3 mJ), which the single point never does: its boxes
# (0.2 m) overlap less than this while falling. @warning scaled for bodies of 0.1 - 10 m.
DEEP_OVERLAP = 0.25

# Largest number of contact points of one shape pair (Box3D: 4).
MAX_MANIFOLD_POINTS = 4

# Face and edge tolerances of the axis choice (Gregorius 2015, "Robust Contact
# Creation", slide "Feature selection"): an edge axis wins only if clearly better than
# the best face, and box b's face only if clearly better than box a's, so that the
# reference face does not flip between steps when two axes are nearly tied (a box
# resting on a box of the same size has two equal face axes).
REL_EDGE_TOLERANCE = 0.90
REL_FACE_TOLERANCE = 0.98
ABS_TOLERANCE = 0.5 * LINEAR_SLOP

# feature-id bases, so that the ids of the different kinds of contact never collide
FEATURE_EDGE = 1 << 12
FEATURE_FACE = 1 << 13

# Most triangle contact points gathered for one (shape, mesh) pair before the reduction
# (pairs/mesh.py); beyond it a new point replaces the shallowest one.
MESH_POINTS = 64
