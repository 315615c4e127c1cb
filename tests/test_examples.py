"""The scene files in examples/, each run and checked against the physics it shows.

Every example is a fixture: it must validate (``tumble validate``), load with
``tumble.load_scene`` and do what its comments say, compared here with closed
forms (free flight, exact flip period, the course's mass sums) and with
conservation laws.
"""

from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.cli import main as cli_main
from tumble.math3d import quat_to_matrix
from tumble.scene import load_scene

from .physics.test_intermediate_axis import exact_flip_interval, sign_change_times

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCENES = sorted(EXAMPLES.glob("*.toml"))


def run(name, **settings):
    """Load examples/NAME.toml, change Scene settings (duration, frame_rate, ...), run it."""
    scene = load_scene(EXAMPLES / f"{name}.toml")
    for key, value in settings.items():
        setattr(scene, key, value)
    scene.check()
    return scene, scene.run(progress=False)


def body_frame_rates(traj, body=0):
    """(F, 3) angular velocity in the body's own axes, omega_body = R^T omega."""
    R = np.array([quat_to_matrix(q) for q in traj.orientation[:, body]])
    return np.einsum("fji,fj->fi", R, traj.angular_velocity[:, body])


def free_flight(x0, v0, g, t):
    """(F, 3) centre of mass of a body under gravity alone: x0 + v0 t + g t^2 / 2."""
    t = np.asarray(t)[:, None]
    return x0 + v0 * t + 0.5 * np.asarray(g) * t**2


# ---------------------------------------------------------------------- every example


def test_the_examples_are_there():
    names = {p.stem for p in SCENES}
    assert {"dzhanibekov", "projectile", "particles", "wind_springs"} <= names
    readme = (EXAMPLES / "README.md").read_text()
    for p in SCENES:
        assert f"tumble run examples/{p.name}" in readme, f"README.md does not list {p.name}"


def test_the_readme_python_example_runs(tmp_path, monkeypatch):
    """The README's ``Use`` block, as a user would paste it (in an empty directory: it writes
    out/trajectory.npz): it runs to the end; its contact scene lands the box on the ground (the
    ray straight down from 5 m above the box's centre meets its top, 4.9 m below, as the box lies
    flat, 0.2 m thick) and its trajectory file exists.
    (The block once added the ground plane under a box that had fallen 417 m through it for 10 s,
    and the contact step blew up: tests/physics/test_contact_issues.py.)"""
    readme = (EXAMPLES.parent / "README.md").read_text()
    code = readme.split("## Use", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert (tmp_path / "out" / "trajectory.npz").exists()
    hits = namespace["hits"]
    assert hits.body[0] == 1 and 4.85 < hits.distance[0] < 5.0


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_example_validates(path, capsys):
    assert cli_main(["validate", str(path)]) == 0
    assert "ok" in capsys.readouterr().out


# ---------------------------------------------------------------------- dzhanibekov


@pytest.fixture(scope="module")
def dzhanibekov():
    # 240 frames a second: every step recorded, so the sign changes of the
    # body y rate are located to a fraction of a step by linear interpolation.
    return run("dzhanibekov", frame_rate=240.0)


def test_dzhanibekov_flips_at_the_exact_interval(dzhanibekov):
    scene, traj = dzhanibekov
    assert scene.duration == 20.0 and scene.integrator == "rk4" and scene.gravity == [0.0, 0.0, 0.0]
    box = scene.world.body("box")
    I_diag = np.diag(box.inertia_body)
    np.testing.assert_allclose(I_diag, 2.0 / 12.0 * np.array([0.6**2 + 1.0**2, 0.2**2 + 1.0**2, 0.2**2 + 0.6**2]), rtol=1e-14)
    omega0_body = np.array([0.01, 5.0, 0.01])
    np.testing.assert_allclose(body_frame_rates(traj)[0], omega0_body, rtol=1e-14, atol=1e-15)

    flips = sign_change_times(traj.time, body_frame_rates(traj)[:, 1])
    assert len(flips) >= 4, f"the box must turn over at least 4 times in 20 s, got {len(flips)}"
    # Against the exact period of Euler's equations (Landau & Lifshitz §37:
    # 2 K(k) / lambda between sign changes). 1 % is the design's tolerance; the
    # interval is averaged over the flips seen, RK4 at 1/240 s is within ~1e-4.
    interval = np.mean(np.diff(flips))
    exact = exact_flip_interval(I_diag, omega0_body)
    assert abs(interval / exact - 1.0) < 0.01, (interval, exact)


def test_dzhanibekov_conserves_energy_and_momentum(dzhanibekov):
    _, traj = dzhanibekov
    # No forces: kinetic energy is a constant of the motion. RK4 at 1/240 s
    # is fourth order, its drift over 20 s is ~3e-10 relative; 1e-8 leaves a
    # margin of 30 yet fails for any second-order integrator or a bug.
    E = traj.kinetic_energy
    assert np.max(np.abs(E / E[0] - 1.0)) < 1e-8
    # No torque: dL/dt = 0 exactly, so every stage adds zero to L; world L is
    # constant to rounding (1e-12 relative to |L| = 0.87 kg m^2/s).
    L = traj.total_angular_momentum
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-12 * np.linalg.norm(L[0])
    # and the centre of mass stays put (no force at all)
    assert np.max(np.abs(traj.position)) < 1e-12


# ---------------------------------------------------------------------- projectile


@pytest.fixture(scope="module")
def projectile():
    return run("projectile")


def test_projectile_flies_the_parabola(projectile):
    scene, traj = projectile
    i = list(traj.names).index("vacuum")
    x0, v0 = traj.position[0, i], traj.velocity[0, i]
    np.testing.assert_array_equal(v0, [4.0, 0.0, 8.0])
    # Gravity alone: x(t) is a polynomial of degree 2, which RK4 integrates
    # exactly; only rounding is left (~1e-14 m over 420 steps), so 1e-9 m.
    expected = free_flight(x0, v0, scene.gravity, traj.time)
    assert np.max(np.abs(traj.position[:, i] - expected)) < 1e-9
    np.testing.assert_allclose(traj.velocity[:, i], v0 + np.outer(traj.time, scene.gravity), rtol=0, atol=1e-9)
    # Gravity acts at the centre of mass: no torque, world L constant (to
    # rounding, 1e-12 relative to |L|).
    L = traj.angular_momentum[:, i]
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-12 * np.linalg.norm(L[0])


def test_projectile_with_drag_lands_short(projectile):
    _, traj = projectile
    names = list(traj.names)
    landing = {}
    for name in ("vacuum", "with_drag"):
        i = names.index(name)
        z = traj.position[:, i, 2] - traj.position[0, i, 2]
        # the first frame after launch back at or below launch height (the
        # duration is chosen so that both get there), then linear interpolation
        k = int(np.flatnonzero((z[1:] <= 0.0) & (z[:-1] > 0.0))[0])
        s = z[k] / (z[k] - z[k + 1])
        landing[name] = (traj.time[k] + s * (traj.time[k + 1] - traj.time[k]),
                         traj.position[k, i, 0] + s * (traj.position[k + 1, i, 0] - traj.position[k, i, 0]),
                         z.max())
    t_vac, x_vac, top_vac = landing["vacuum"]
    t_drag, x_drag, top_drag = landing["with_drag"]
    # the vacuum flight time is 2 v0z / g (to the interpolation's error between frames)
    assert abs(t_vac - 2 * 8.0 / 9.81) < 1e-3
    # Drag only takes energy away: lower apex, earlier and shorter landing.
    # Margins well beyond interpolation errors (~1e-3): c = 0.01 N s^2/m^2 on
    # 0.5 kg shortens the range by ~10 % (~0.6 m).
    assert top_drag < top_vac - 0.05
    assert t_drag < t_vac - 0.01
    assert x_drag < x_vac - 0.1
    # drag acts at the centre of mass too: L stays constant
    L = traj.angular_momentum[:, names.index("with_drag")]
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-12 * np.linalg.norm(L[0])


# ---------------------------------------------------------------------- particles


def test_particles_mass_properties_are_the_course_sums():
    scene = load_scene(EXAMPLES / "particles.toml")
    spec = scene.data["bodies"][0]
    points = np.array(spec["shape"]["points"], dtype=float)
    masses = np.array(spec["shape"]["masses"], dtype=float)
    # The course's sums, written out point by point (Baraff 2001, "Rigid body
    # concepts"): M = sum m_i; c = sum m_i r_i / M; Ibody = sum m_i (r'.r' 1 - r' r'^T).
    M = 0.0
    first = np.zeros(3)
    for m, r in zip(masses, points):
        M += m
        first += m * r
    c = first / M
    I = np.zeros((3, 3))
    for m, r in zip(masses, points):
        rp = r - c
        I += m * (np.dot(rp, rp) * np.eye(3) - np.outer(rp, rp))
    assert np.linalg.norm(c) > 0.05, "the example must not be centred on its origin"

    ell = scene.world.body("ell")
    # Sums of ten terms of size ~0.1: agreement to 1e-12 allows for a
    # different summation order only.
    assert abs(ell.mass - M) < 1e-12
    np.testing.assert_allclose(ell.com_offset, c, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ell.inertia_body, I, rtol=0, atol=1e-12)
    # Re-centred: the body frame sits at the centre of mass, i.e. the shape
    # origin given as "position" plus R c (R = 1 here).
    np.testing.assert_allclose(ell.x, np.array(spec["position"]) + c, rtol=0, atol=1e-12)


def test_particles_fly_free():
    scene, traj = run("particles")
    x0, v0 = traj.position[0, 0], traj.velocity[0, 0]
    # Gravity alone: a parabola, exact under RK4 up to rounding (the speed
    # reaches 25 m/s over 5 s: rounding ~1e-13 m), hence 1e-9 m.
    assert np.max(np.abs(traj.position[:, 0] - free_flight(x0, v0, scene.gravity, traj.time))) < 1e-9
    # Gravity gives no torque about the centre of mass: L constant (1e-12
    # relative) while omega wobbles (the spin is off the principal axes).
    L = traj.angular_momentum[:, 0]
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-12 * np.linalg.norm(L[0])
    omega = traj.angular_velocity[:, 0]
    assert np.max(np.linalg.norm(omega - omega[0], axis=1)) > 0.1, "the L should wobble"
    # and the rotational kinetic energy is constant (RK4, 1e-8 relative over 5 s)
    E_rot = 0.5 * np.sum(traj.angular_momentum[:, 0] * omega, axis=1)
    assert np.max(np.abs(E_rot / E_rot[0] - 1.0)) < 1e-8


# ---------------------------------------------------------------------- wind_springs


def test_wind_springs_settles_at_the_static_equilibrium():
    scene, traj = run("wind_springs")
    w = scene.world
    sign = w.body("sign")
    weight = sign.mass * np.linalg.norm(w.gravity)
    # Comes to rest: every mode is damped (cords along their length, air drag
    # for the swing, rotational drag for the twist). At 10 s the plate moves at
    # ~1e-8 m/s; 1e-5 m/s and rad/s (tighter than "at rest" needs, 1e-3) so
    # that the damping forces left over, <= (c1 + 2 c2 |w| + 2 damping) |v|
    # ~ 2e-4 N, cannot hide in the equilibrium check below.
    assert np.linalg.norm(sign.v) < 1e-5
    assert np.linalg.norm(sign.omega) < 1e-5
    # ... and was moving on the way (it did not start at equilibrium)
    assert np.max(np.linalg.norm(traj.velocity[:, 0], axis=1)) > 0.1
    # Displaced downwind (+y, the wind's direction) by a visible amount.
    wind = np.array(scene.data["forces"][2]["wind"], dtype=float)
    assert wind[1] > 0 and sign.x[1] - traj.position[0, 0, 1] > 0.2

    # Static equilibrium: the accumulated force of the run's last state
    # (world.force: springs + gravity + drag, evaluated by update_derived()
    # after the last step) is ~0: within 1e-3 of the weight, 50 times the
    # damping forces the residual speed can leave (above).
    assert np.linalg.norm(w.force[0]) < 1e-3 * weight
    assert np.linalg.norm(w.torque[0]) < 1e-3 * weight * 0.3  # N m: weight times the half-width

    # The same balance recomputed here from the records' formulas at zero
    # velocity: Hooke's law along each cord, m g, and drag of the wind on a
    # body at rest, -(c1 + c2 |u|) u with u = -wind.
    total = sign.mass * w.gravity
    for f in w.forces:
        if isinstance(f, tb.Spring):
            pa, pb = w.spring_endpoints(f)
            d = pa - pb
            l = np.linalg.norm(d)
            total = total - f.stiffness * (l - f.rest_length) * d / l
        elif isinstance(f, tb.Drag):
            u = -np.asarray(f.wind)
            total = total - (f.linear + f.quadratic * np.linalg.norm(u)) * u
    assert np.linalg.norm(total) < 1e-3 * weight
    # the wind's push at rest, (1.5 + 0.5 * 3) * 3 = 9 N, is carried by the
    # cords, which therefore lean downwind
    for f in w.forces:
        if isinstance(f, tb.Spring):
            pa, pb = w.spring_endpoints(f)
            assert pa[1] - pb[1] > 0.2
