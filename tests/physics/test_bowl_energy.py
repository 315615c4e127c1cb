"""A frictionless ball oscillating in a finely faceted static bowl must not gain energy.

Scenes: a ball (r 0.1 m, 1 kg) let go 0.05 rad up a spherical bowl (R 1 m), frictionless, at the
default dt 1/240 s: an open sheet of 256 x 128 triangles over 30 degrees (0.23 degree rings, 4 mm
at R) and a heightfield of 4 mm cells. The ball (25 times the facets) touches several of them at
once. Before the fix (collision/pairs/mesh.py, ``BESIDE_SPHERE``) the next facet's contact was made
only once the ball's centre was over it, by when the ball had run on into its plane during the
step; the push-out then lifted it without the kinetic energy the climb costs: +0.35 mJ in 3 s on
the heightfield (+18 % of the 11.0 mJ oscillation in 15 s), +50 % in 30 s on the sheet.

Compared with: E(0) (E = KE + m g z; a conservative motion, which contacts may only damp) and the
period of the frictionless small oscillation, 2 pi sqrt((R - r) / g) (1 + theta0^2 / 16).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumble as tb

G = 9.81
R, RADIUS, THETA0 = 1.0, 0.1, 0.05
DT = 1.0 / 240.0
CELL = 0.004  # m: the heightfield's cells; the sheet's rings are 0.23 deg * 1 m = 4 mm
# The tolerance on E(t) - E(0) (J, for 1 kg): the ball's height relative to the ideal bowl moves by
# the facets' sagitta (chords inside the sphere: CELL^2 / (8 R) = 2.0 um) and by its soft contacts'
# sag under its weight (g / omega^2 at the static contact's 240 Hz of the default substep 1/960 s:
# 4.3 um), which the energy KE + m g z does not count: m g (2.0 + 4.3) um = 0.06 mJ. The bug gained
# 0.35 mJ in these 3 s (heightfield) and 0.5 mJ (sheet); the float rounding of E (~1 J) is 1e-16 J.
SAG = G / (2.0 * math.pi * 240.0) ** 2
TOLERANCE = G * (CELL ** 2 / (8.0 * R) + SAG)
SECONDS = 3.0


def bowl_sheet(nlon=256, nlat=128, tmax=math.radians(30.0)):
    """An open spherical cap of radius R, lowest point at the origin: a fan of ``nlon`` triangles
    around the pole, then ``nlat - 1`` rings of 2 ``nlon`` triangles."""
    V = [[0.0, 0.0, 0.0]]
    F = []
    for i in range(1, nlat + 1):
        t = tmax * i / nlat
        for j in range(nlon):
            p = 2.0 * math.pi * j / nlon
            V.append([R * math.sin(t) * math.cos(p), R * math.sin(t) * math.sin(p), R - R * math.cos(t)])
    for j in range(nlon):
        F.append([0, 1 + j, 1 + (j + 1) % nlon])
    for i in range(nlat - 1):
        for j in range(nlon):
            a = 1 + i * nlon + j
            b = 1 + i * nlon + (j + 1) % nlon
            F += [[a, a + nlon, b + nlon], [a, b + nlon, b]]
    return tb.Mesh(vertices=np.array(V), faces=np.array(F), closed=False)


def bowl_heightfield(half=0.6):
    n = int(round(2 * half / CELL)) + 1
    x = np.linspace(-half, half, n)
    X, Y = np.meshgrid(x, x)
    return tb.heightfield(R - np.sqrt(R ** 2 - X ** 2 - Y ** 2), (2 * half, 2 * half), base=0.1)


def oscillate(shape, dt=DT):
    """E(t) - E(0) (J) after each step of ``dt`` (s), the ball's x (m) and the times (s)."""
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = False
    w.add_body(shape, fixed=True, material=tb.Material(friction=0.0))
    c = np.array([0.0, 0.0, R]) + (R - RADIUS) * np.array([math.sin(THETA0), 0.0, -math.cos(THETA0)])
    ball = w.add_body(tb.Sphere(RADIUS), mass=1.0, position=tuple(c), material=tb.Material(friction=0.0))
    sim = tb.Simulator(w, dt=dt)

    def energy():
        return 0.5 * float(np.dot(ball.v, ball.v)) + 0.5 * float(np.dot(ball.omega, np.array(ball.L))) \
            + G * float(ball.x[2])

    e0 = energy()
    steps = int(round(SECONDS / dt))
    de, xs = np.zeros(steps), np.zeros(steps)
    for k in range(steps):
        sim.step(1)
        de[k] = energy() - e0
        xs[k] = ball.x[0]
    return de, xs, dt * np.arange(1, steps + 1)


@pytest.mark.parametrize("kind", ["sheet", "heightfield"])
def test_ball_in_a_fine_faceted_bowl_gains_no_energy(kind):
    de, xs, ts = oscillate(bowl_sheet() if kind == "sheet" else bowl_heightfield())
    assert de.max() <= TOLERANCE, f"gained {de.max() * 1e3:.3f} mJ at t = {ts[de.argmax()]:.3f} s"
    # the period of the small oscillation (frictionless: the pendulum of length R - r)
    s = np.sign(xs)
    i = np.nonzero(s[1:] != s[:-1])[0]
    crossings = ts[i] - xs[i] * (ts[i + 1] - ts[i]) / (xs[i + 1] - xs[i])
    assert len(crossings) >= 3
    period = 2.0 * np.mean(np.diff(crossings))
    expected = 2.0 * math.pi * math.sqrt((R - RADIUS) / G) * (1.0 + THETA0 ** 2 / 16.0)
    assert period == pytest.approx(expected, rel=0.01)


@pytest.mark.xfail(strict=True, reason="the band beside a face (collision/pairs/mesh.py, BESIDE_SPHERE: 1 mm) covers "
                   "the step's travel at 1/240 s; at 1/60 s the ball moves 2.5 mm a step and still runs into the "
                   "next facet's plane before it makes a contact: +2.2 mJ in 3 s (+20 %; before the band +2.15)")
def test_ball_in_a_fine_faceted_bowl_gains_no_energy_at_dt_1_60():
    de, _, ts = oscillate(bowl_heightfield(), dt=1.0 / 60.0)
    assert de.max() <= TOLERANCE, f"gained {de.max() * 1e3:.3f} mJ at t = {ts[de.argmax()]:.3f} s"
