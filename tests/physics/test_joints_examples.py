"""The scene files in examples/joints/, each checked against the physics it shows: those
without contact with the standalone joint stepper, those with contact (ragdoll, Newton's
cradle) through the Simulator's soft step, which solves contacts and joints together."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipk

from tumble.scene_joints import load_scene_with_joints
from tumble.solver.joints import JointSolver, step_with_joints

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "joints"


def load(name):
    scene, joints, settings = load_scene_with_joints(EXAMPLES / name)
    return scene, joints, JointSolver(settings)


def run(scene, solver, seconds, each=None):
    w = scene.world
    for k in range(round(seconds / scene.dt)):
        if each is not None:
            each(k, w, solver)
        step_with_joints(w, solver, scene.dt, scene.substeps)


def test_every_example_loads():
    names = sorted(p.name for p in EXAMPLES.glob("*.toml"))
    assert len(names) == 10
    for name in names:
        scene, joints, _solver = load(name)
        assert joints and len(scene.world.joints) == len(joints)


def test_ragdoll_example_tumbles_down_the_stairs_within_its_limits():
    # Through the Simulator's soft step (contacts and joints together), as `tumble run` does.
    import tumble as tb

    scene = tb.load_scene(EXAMPLES / "ragdoll_stairs.toml")
    w = scene.world
    sim = scene.simulator()
    sim.run(4.0, 10, progress=False)
    pelvis = w.body("pelvis")
    assert pelvis.x[0] > 2.4  # past the last step (the flight ends at x = 2.4 m)
    assert pelvis.x[2] < 0.3  # down on the ground
    r = sim.joint_readings()
    assert r["enabled"].all()
    knees = r["position"][[7, 9]]
    elbows = r["position"][[3, 5]]
    assert np.all(knees > -0.05) and np.all(knees < math.radians(150) + 0.05)
    assert np.all(elbows < 0.05) and np.all(elbows > -math.radians(150) - 0.05)


def test_reeds_example_ball_knocks_reeds_aside_and_they_spring_back_to_the_winds_lean():
    """Nine identical stalks on driven ball joints lean in a steady wind; the ball thrown through the
    bed strikes some of them (their tips swing more than 20 cm off the others' pose), and by the end
    (10 s) every reed is back in the pose of the ones it missed, tip within 5 mm of theirs (measured:
    1.2 mm, the last of the swaying; 0.1 mm at 15 s): the drives' static equilibrium is one, whatever
    the path (before the drive's anchor part was kept at the present arms, a struck reed settled 3 cm
    off for good). The lean is the wind's: each reed
    bends downwind (+x, +y) and none falls (tip above 1 m of its 1.25 m)."""
    import tumble as tb

    scene = tb.load_scene(EXAMPLES / "reeds.toml")
    w = scene.world
    sim = scene.simulator()
    tips = [w.index_of(f"reed{r}{c}_5") for r in range(3) for c in range(3)]
    roots = np.array([w.x[w.index_of(f"reed{r}{c}_0")] for r in range(3) for c in range(3)])

    def offsets():
        return np.array([w.x[t] for t in tips]) - roots

    largest = np.zeros(9)
    for _ in range(100):
        sim.step(24)
        off = offsets()
        typical = np.median(off, axis=0)
        largest = np.maximum(largest, np.linalg.norm(off - typical, axis=1))
    struck = largest > 0.2
    assert 2 <= struck.sum() <= 6, largest
    off = offsets()
    assert np.abs(off - np.median(off[~struck], axis=0)).max() < 5e-3, off
    lean = off[0] - np.array([0.0, 0.0, w.x[tips[0]][2] - roots[0][2]])
    assert lean[0] > 0.2 and lean[1] > 0.05  # downwind
    assert np.all(np.array([w.x[t][2] for t in tips]) > 1.0)
    assert r_enabled(sim)


def r_enabled(sim):
    return bool(sim.joint_readings()["enabled"].all())


def test_newtons_cradle_example_sends_one_ball_out():
    # Compared with momentum and energy before the strike (the 1 %): the last ball
    # leaves at the first ball's impact speed, the middle ones stay. Through the Simulator.
    import tumble as tb

    scene = tb.load_scene(EXAMPLES / "newtons_cradle.toml")
    w = scene.world
    E0 = w.kinetic_energy() + w.potential_energy()
    traj = scene.simulator().run(1.2, 240, progress=False)
    vx = traj.velocity[:, :, 0]
    u = vx[:, 0].max()
    k = int(np.argmax(vx[:, 4]))
    assert vx[k, 4] == pytest.approx(u, rel=0.01)
    assert np.abs(vx[k, :4]).max() < 0.01 * u
    E = traj.kinetic_energy[-1] + traj.potential_energy[-1]
    assert E == pytest.approx(E0, rel=0.01)


@pytest.mark.slow
def test_chain_over_box_example_drapes_over_the_box():
    """examples/joints/chain_over_box.toml through the Simulator (contacts and joints in one step):
    after 5 s the chain hangs over the 0.6 m box: the links over the box lie on its top (centre
    at its top plus a link radius, within 5 mm), none is inside the box or below the ground by
    more than 5 mm, links lie on both sides of it, and every joint holds (gap under 1 % of the
    8 cm link spacing)."""
    import tumble as tb

    scene = tb.load_scene(EXAMPLES / "chain_over_box.toml")
    sim = scene.simulator()
    sim.run(scene.duration, scene.frame_rate, progress=False)
    w = scene.world
    links = np.arange(2, w.body_count)
    x = w.x[links]
    r = 0.015
    over = np.abs(x[:, 0]) < 0.3 - 2 * r
    assert over.any() and np.all(np.abs(x[over, 2] - (0.6 + r)) < 0.005)
    inside = (np.abs(x[:, 0]) < 0.3 - r) & (np.abs(x[:, 1]) < 0.3 - r) & (x[:, 2] < 0.6)
    assert not inside.any()
    assert x[:, 2].min() > r - 0.005
    assert (x[:, 0] < -0.3).any() and (x[:, 0] > 0.3).any()
    solver = sim.soft_step.joints
    a, b = solver.joint_a, solver.joint_b
    pa = np.einsum("jkl,jl->jk", w.R[a], solver.local_a) + w.x[a]
    pb = np.einsum("jkl,jl->jk", w.R[b], solver.local_b) + w.x[b]
    assert np.linalg.norm(pa - pb, axis=1).max() < 0.01 * 0.08


def test_geared_flywheel_example_period_and_gear():
    # Compared with the reduced pendulum: the flywheel (I_w = 0.18 kg m^2 about its axle) geared 3:1
    # counts 9 I_w in the swing's inertia, so the period is the exact elliptic one with omega0^2 =
    # m g l / (I_p + 9 I_w): 3.304 s against 2.042 alone. Through the Simulator (as `tumble run`),
    # the tree method at dt 1/240 s: the period measured 2.8e-9 off (the first-order error of the
    # step shifts the phase, not the mean period, to first order); bound 1e-6. The gear holds
    # to 1.3e-15 rad; bound 1e-12.
    import tumble as tb

    scene = tb.load_scene(EXAMPLES / "geared_flywheel.toml")
    sim = scene.simulator()
    xs = []
    for _ in range(round(7.0 / scene.dt)):
        sim.step()
        xs.append(scene.world.x[0, 0])
        r = sim.joint_readings()
        assert abs(r["position"][1] - 3.0 * r["position"][0]) < 1e-12
    xs = np.array(xs)
    idx = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
    t = (idx + xs[idx] / (xs[idx] - xs[idx + 1])) * scene.dt
    omega0 = math.sqrt(9.81 / (1 + 0.4 * 0.05**2 + 9 * 0.5 * 4.0 * 0.3**2))
    period = 4 * ellipk(math.sin(math.radians(15)) ** 2) / omega0
    assert np.diff(t).mean() == pytest.approx(period, rel=1e-6)


def test_pendulum_example_period():
    scene, _, solver = load("pendulum.toml")
    xs = []
    run(scene, solver, 4.2, each=lambda k, w, s: xs.append(w.x[0, 0]))
    xs = np.array(xs)
    idx = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
    t = (idx + xs[idx] / (xs[idx] - xs[idx + 1])) * scene.dt
    omega0 = math.sqrt(9.81 / (1 + 0.4 * 0.05**2))
    period = 4 * ellipk(math.sin(math.radians(15)) ** 2) / omega0
    assert np.diff(t).mean() == pytest.approx(period, rel=1e-4)


def test_hinged_door_example_opens_and_stops_at_its_limit():
    scene, _joints, solver = load("hinged_door.toml")
    w = scene.world
    push = next(f for f in w.forces if type(f).__name__ == "Impulse")
    angles = []

    def each(k, w, s):
        # the standalone stepper applies no Impulse records: apply the push by hand at its time
        if abs(k * scene.dt - push.time) < 0.5 * scene.dt:
            r = np.asarray(push.point) - w.x[0]
            w.P[0] += push.impulse
            w.L[0] += np.cross(r, push.impulse)
        angles.append(float(s.position[0]) if s.count else 0.0)

    run(scene, solver, 3.0, each=each)
    assert max(angles) > math.radians(90)  # swung open ...
    assert max(angles) < math.radians(100) + 0.02  # ... but not past its stop
    assert min(angles) > -0.02


def test_four_bar_example_turns_at_motor_speed_with_loop_closed():
    scene, _, solver = load("four_bar.toml")
    rates, gaps = [], []

    def each(k, w, s):
        if k > 60:
            rates.append(float(s.rate[0]))
            pa = w.R[2] @ s.local_a[3] + w.x[2]
            gaps.append(float(np.linalg.norm(pa - s.local_b[3])))

    run(scene, solver, 2.0, each=each)
    assert np.mean(rates) == pytest.approx(2 * math.pi, rel=0.01)
    assert max(gaps) < 5e-3
    assert solver.position[0] > 2 * math.pi  # more than a full turn of the crank


def test_heavy_top_example_precesses():
    scene, _, solver = load("heavy_top.toml")
    w = scene.world
    run(scene, solver, 1.0)
    axis = w.R[0][:, 2]
    # precessed about the vertical by ~0.45 rad/s x 1 s, keeping its tilt near 30 deg
    assert math.degrees(math.acos(axis[2])) == pytest.approx(30.0, abs=3.0)
    assert abs(math.atan2(axis[1], axis[0]) - math.atan2(-0.5, 0.0)) > 0.2


def test_double_pendulum_example_energy():
    scene, _, solver = load("double_pendulum.toml")
    w = scene.world
    E0 = w.kinetic_energy() + w.potential_energy()
    run(scene, solver, 2.0)
    E = w.kinetic_energy() + w.potential_energy()
    assert abs(E - E0) / (E0 + 3 * 9.81) < 1e-3
