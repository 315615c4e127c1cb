"""Contacts of jointed bodies solved through the joint tree (``tumble.solver.contact_tree``) and the
tree's limit rows (``joint_tree.tree_limits_kernel``): each row's mass is the articulated bodies'
(checked against the lever's reduced-coordinate inertia), and a mechanism on contacts and limits
comes to rest (it did not: the contacts saw the free bodies' masses, the limits pushed rigidly)."""


import numpy as np
import pytest

import tumble as tb
from tumble.joints import HingeJoint
from tumble.solver.joints import ACCURATE

G = 9.81
M, LENGTH, DEPTH, HEIGHT = 2.0, 1.0, 0.1, 0.05  # the lever: a box rod, kg and m
TIP = 0.8  # m from the hinge: the support's x


def lever(armature: float):
    """A rod hinged to the world at its left end (x = 0, z = 1, axis y), lying level on a fixed ball
    under x = TIP, frictionless: (world, simulator at 1/240 s, the tree method)."""
    w = tb.World(gravity=(0.0, 0.0, -G))
    w.sleeping = False
    rod = w.add_body(tb.Box(size=(LENGTH, DEPTH, HEIGHT)), mass=M, position=(LENGTH / 2, 0, 1.0), name="rod")
    w.add_joint(HingeJoint("world", rod, anchor=(0, 0, 1.0), axis=(0, 1, 0), armature=armature))
    radius = 0.1
    # frictionless: with friction the rod's landing leaves a horizontal force between the support and
    # the hinge (the point below the hinge's axis slides as the rod turns), which the moments then share
    w.add_body(tb.Sphere(radius), fixed=True, position=(TIP, 0, 1.0 - HEIGHT / 2 - radius), name="support",
               material=tb.Material(friction=0.0))
    return w, tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)


@pytest.mark.parametrize("armature", [0.0, 0.5])
def test_a_contact_on_a_hinged_rod_has_the_rods_inertia_about_its_hinge(armature):
    """The contact under the rod at TIP from the hinge, its arm r = (TIP - L/2, 0, -h/2) from the
    rod's centre: through the tree, a unit impulse along z turns the rod about the hinge, so the
    normal row's mass is (I_hinge + a) / TIP^2 and the friction row along x's (I_hinge + a) / (h/2)^2
    (the point below the hinge's axis moves along x as the rod turns), I_hinge = m (L^2 + h^2) / 12
    + m (L/2)^2: the reduced coordinate's inertia, exactly (to 1e-12: rounding). The free rod's
    normal mass would be 1 / (1/m + r_x^2 / I_cm): 0.70 kg against 1.04 kg without armature. Along y
    the hinge holds the point: no response (rounding, 4e-17 of the free rod's), mass 0, not 1/4e-17."""
    w, sim = lever(armature)
    sim.step(1)
    tree = sim.soft_step.tree_contacts
    assert len(tree.contacts) == 1
    inertia = M * (LENGTH ** 2 + HEIGHT ** 2) / 12 + M * (LENGTH / 2) ** 2 + armature
    c = tree.contacts[0]
    solver = sim.soft_step.solver
    n = solver.contacts.contact_normal[c]
    t1, t2 = solver.tangent1[c], solver.tangent2[c]
    expected = []
    for u in (n, t1, t2):
        # the point's rate along u per unit hinge rate: (omega_y y) x r_hinge . u, r_hinge = (TIP, 0, -h/2)
        lever_arm = np.cross([0.0, 1.0, 0.0], [TIP, 0.0, -HEIGHT / 2]) @ u
        expected.append(inertia / lever_arm ** 2 if abs(lever_arm) > 1e-9 else 0.0)
    np.testing.assert_allclose(tree.row_mass[:3], expected, rtol=1e-12, atol=1e-9)
    assert abs(abs(n[2]) - 1.0) < 1e-12


@pytest.mark.parametrize("armature", [0.0, 0.5])
def test_a_hinged_rod_on_a_support_rests_with_the_levers_force(armature):
    """Let go level on its support, the rod rests: every rate under 1e-9 rad/s after 2 s, and the
    contact force's moment about the hinge balances the weight's (statics, at the pose it rests in:
    about m g (L/2) / TIP = 12.26 N at the support), to 1e-9 of the weight's moment; the hinge takes
    the rest. (A lever this simple rested with the contacts solved apart from the tree too: the
    mechanisms that did not are the ant's and the humanoid's, tests/test_envs_humanoid.py.)"""
    w, sim = lever(armature)
    sim.step(480)
    assert np.abs(w.omega).max() < 1e-9
    assert np.abs(w.v).max() < 1e-9
    c = sim.contacts()
    assert len(c) == 1
    hinge = np.array([0.0, 0.0, 1.0])
    rod = w.body("rod")
    # the moments about the hinge's axis (y): the support's force on the rod (b gets +force, a -force)
    on_rod = c.force[0] if c.body_b[0] == rod.index else -c.force[0]
    contact_moment = np.cross(c.point[0] - hinge, on_rod)[1]
    weight_moment = np.cross(np.asarray(rod.x) - hinge, [0.0, 0.0, -M * G])[1]
    assert contact_moment + weight_moment == pytest.approx(0.0, abs=1e-9 * abs(weight_moment))
    assert abs(c.force[0] @ c.normal[0]) == pytest.approx(M * G * (LENGTH / 2) / TIP, rel=1e-4)


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_a_ball_strikes_a_hinged_bar_with_the_impact_law_of_its_inertia_about_the_hinge(e):
    """A 1 kg ball at 3 m/s strikes a 0.2 kg bar (1 x 0.1 x 0.1 m) hinged to the world at its end
    (vertical axis), 0.8 m out, square on, frictionless, restitution e, no gravity: Newton's impact
    law with the bar's mass at the point, m_b = I_hinge / r^2 = 0.105 kg, gives the ball
    (1 - e m_b) / (1 + m_b) v and the bar (1 + e) v / ((1 + m_b) r) (angular momentum about the
    hinge and the law of restitution; e = 1 keeps the energy). Measured: the ball to 2e-16, the bar's
    rate 1.9e-5 and the energy 1.3e-5 off (the bar turns a little within the step of the impact, its
    response taken at the step's start); bound 1e-4 relative.
    With the restitution pass on the free bar's mass (before session 35): 2.4712 m/s, 2.4 % of
    the energy lost at e = 1; with the contacts through the tree but that pass free: 2.4519."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.sleeping = False
    material = tb.Material(friction=0.0, restitution=e)
    bar = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=0.2, position=(0.5, 0.0, 0.0), material=material)
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0.8, -0.5, 0.0), velocity=(0.0, 3.0, 0.0),
                      material=material)
    w.add_joint(HingeJoint("world", bar, anchor=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)))
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    energy = w.kinetic_energy()
    sim.step(120)
    inertia = 0.2 * (1.0 + 0.01) / 12 + 0.2 * 0.5 ** 2
    m_b = inertia / 0.8 ** 2
    assert w.v[ball.index][1] == pytest.approx((1 - e * m_b) / (1 + m_b) * 3.0, rel=1e-4)
    assert w.omega[bar.index][2] == pytest.approx((1 + e) * 3.0 / ((1 + m_b) * 0.8), rel=1e-4)
    if e == 1.0:
        assert w.kinetic_energy() == pytest.approx(energy, rel=1e-4)
