"""A 50-link chain holding a body 100 times heavier than a link (the hard case of
iterative joint solvers: a heavy body on light links)."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.joints import BallJoint
from tumble.solver.joints import ACCURATE, JointSettings, JointSolver, step_with_joints

LINKS, LINK_LENGTH, LINK_MASS = 50, 0.1, 0.1


def build_chain(angle_deg):
    """Links (0.02 x 0.02 x 0.1 m boxes) from a world anchor at the origin along a line
    angle_deg from the downward vertical, ball joints at their ends, a sphere of 100 link
    masses at the end."""
    a = math.radians(angle_deg)
    d = np.array([math.sin(a), 0.0, -math.cos(a)])
    # body z (the link's long axis) along d: a turn of pi - a about y
    half = 0.5 * (math.pi - a)
    q = (math.cos(half), 0.0, math.sin(half), 0.0)
    w = tb.World()
    prev = None
    for i in range(LINKS):
        link = w.add_body(tb.Box((0.02, 0.02, LINK_LENGTH)), mass=LINK_MASS, position=(i + 0.5) * LINK_LENGTH * d,
                          orientation=q, name=f"link{i}")
        w.add_joint(BallJoint(link, prev, anchor=i * LINK_LENGTH * d))
        prev = link
    radius = 0.1
    heavy = w.add_body(tb.Sphere(radius), mass=100 * LINK_MASS, position=(LINKS * LINK_LENGTH + radius) * d,
                       name="heavy")
    w.add_joint(BallJoint(heavy, prev, anchor=LINKS * LINK_LENGTH * d))
    return w


def stretch(w, solver):
    """Sum of the joints' anchor gaps over the chain's length (0 for an unstretched chain)."""
    a, b = solver.joint_a, solver.joint_b
    pa = np.einsum("jkl,jl->jk", w.R[a], solver.local_a) + w.x[a]
    bb = np.maximum(b, 0)
    pb = np.where((b >= 0)[:, None], np.einsum("jkl,jl->jk", w.R[bb], solver.local_b) + w.x[bb], solver.local_b)
    return float(np.linalg.norm(pa - pb, axis=1).sum()) / (LINKS * LINK_LENGTH)


def run(angle_deg, settings, dt, substeps, seconds):
    w = build_chain(angle_deg)
    solver = JointSolver(settings)
    worst = 0.0
    for _ in range(round(seconds / dt)):
        step_with_joints(w, solver, dt, substeps)
        worst = max(worst, stretch(w, solver))
    return worst, w


@pytest.mark.parametrize("angle_deg", [0.0, 60.0])
def test_chain_with_heavy_body_stretches_under_1_percent(angle_deg):
    # Compared with the chain's own length (the bound, 1 %). Exact tree solve of the
    # ball joints (ACCURATE), dt 1/60 s with 8 substeps, 3 s. Measured: hanging 0 (to
    # rounding), released from 60 deg max 6.6e-6 while it swings through.
    # NOTE: with 4 substeps (h = 1/240 s) the swing passes through a transient of over 50 %
    # before it recovers, and Box2D's settings (soft 60 Hz rows, 1 Gauss-Seidel sweep)
    # stretch 33 % hanging and over 100 % swinging: see docs/joints.md.
    worst, w = run(angle_deg, ACCURATE, 1 / 60, 8, 3.0)
    assert worst < 0.01, worst
    assert np.all(np.isfinite(w.x))


def test_gauss_seidel_chain_is_the_hard_case():
    # Documents why the tree solve exists: Box2D's defaults on the same hanging chain.
    worst, _ = run(0.0, JointSettings(), 1 / 60, 4, 1.0)
    assert worst > 0.05
