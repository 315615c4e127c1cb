"""The step linearized by finite differences (``Kinematics.transition_jacobians``, MuJoCo's
``mjd_transitionFD``), against the closed form of the soft step's own scheme, the exact flow,
the joint-space mass matrix and MuJoCo's own ``mjd_transitionFD`` on the same files."""

import numpy as np
import pytest
import scipy.linalg as sl

import tumble as tb
from tumble.checks import state_hash
from tumble.errors import InputError
from tumble.solver.joints import JointSettings

DT = 1 / 240
SUBSTEPS = 4  # the soft step's default (SoftStepSettings.substeps)

# one hinge about y, a 2 kg ball of radius 0.05 m 1 m below it, a motor on the hinge
PENDULUM = """<mujoco model="pend">
  <option timestep="{dt!r}" integrator="Euler"/>
  <worldbody>
    <body name="arm" pos="0 0 2">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom name="bob" type="sphere" size="0.05" pos="0 0 -1" mass="2"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="torque" joint="hinge" gear="1"/>
  </actuator>
</mujoco>"""
MASS, ARM, RADIUS = 2.0, 1.0, 0.05
I_PIVOT = MASS * ARM**2 + 0.4 * MASS * RADIUS**2  # kg m^2 about the hinge
K = MASS * 9.81 * ARM  # N m/rad: the torque of gravity per radian at the bottom


def _pendulum(tmp_path, method="tree"):
    path = tmp_path / "pend.xml"
    path.write_text(PENDULUM.format(dt=DT))
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, str(path))
    sim = tb.Simulator(world, dt=DT, joint_settings=JointSettings(method=method))
    return path, world, robot, sim


def test_a_pendulum_at_the_bottom_gives_the_soft_steps_own_linear_map(tmp_path):
    """Hanging at rest, the step is linear in (q, q', u) up to O(q^3): the soft step's 4 substeps of
    semi-implicit Euler, each hs = h/4 (v += hs (u - K q) / I; q += hs v; the tree solve keeps the
    hinge exact), make A = S^4 and B = sum S^j b with S = [[1 - hs^2 K/I, hs], [-hs K/I, 1]],
    b = [hs^2/I, hs/I]. The finite differences (centred, eps 1e-6: truncation O(eps^2), round-off
    1e-16/1e-6) reproduce it to 1e-9 (measured 7e-15: the map is linear here up to O(q^3), which
    centred differences cancel). Against the exact flow expm(J h) the scheme is off by O(hs^2 K/I)
    per substep, 2.1e-5 on the diagonal (measured): checked to 5e-5."""
    _, _, robot, sim = _pendulum(tmp_path)
    lin = robot.kinematics.transition_jacobians(sim)
    assert lin.A.shape == (2, 2) and lin.B.shape == (2, 1) and lin.inputs == ["torque"] and lin.dt == DT
    hs = DT / SUBSTEPS
    S = np.array([[1 - hs * hs * K / I_PIVOT, hs], [-hs * K / I_PIVOT, 1.0]])
    b = np.array([hs * hs / I_PIVOT, hs / I_PIVOT])
    A = np.linalg.matrix_power(S, SUBSTEPS)
    B = sum(np.linalg.matrix_power(S, j) @ b for j in range(SUBSTEPS))
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lin.B[:, 0], B, rtol=1e-6, atol=0)
    flow = sl.expm(np.array([[0.0, 1.0], [-K / I_PIVOT, 0.0]]) * DT)
    np.testing.assert_allclose(lin.A, flow, rtol=0, atol=5e-5)
    assert np.abs(lin.A - flow).max() > 1e-6  # and the scheme's error is seen (it is not the flow itself)


def test_mujoco_linearizes_the_same_pendulum_to_within_their_schemes_difference(tmp_path):
    """MuJoCo's ``mjd_transitionFD`` on the same file (its Euler, one step of h): A differs from
    tumble's by the two first-order schemes' difference, O(h^2 K / I) (measured 6.4e-5 on the
    diagonal, 1e-6 off it; checked under 2 h^2 K / I = 3.4e-4); the velocity row of B (h / I either
    way) to 1e-4 relative (measured 2.7e-5). Same layout, same signs, same input."""
    mujoco = pytest.importorskip("mujoco")
    path, _, robot, sim = _pendulum(tmp_path)
    lin = robot.kinematics.transition_jacobians(sim)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    A, B = np.zeros((2, 2)), np.zeros((2, 1))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
    assert np.abs(lin.A - A).max() < 2 * DT * DT * K / I_PIVOT
    assert lin.B[1, 0] == pytest.approx(B[1, 0], rel=1e-4)


def test_a_free_body_moves_by_its_velocity_and_turns_by_its_rate(tmp_path):
    """A free joint (7 positions, 6 rates) in empty space: x' = x + h v and q' = q exp(w h) exactly,
    so about a state at rest A = [[1, h 1], [0, 1]] (12 x 12) in the tangent space (the rotation's
    3 rates in the body frame, MuJoCo's): the layout and the quaternion's difference are right."""
    path = tmp_path / "free.xml"
    path.write_text("""<mujoco><worldbody><body name="box" pos="0 0 1" euler="20 30 40">
      <freejoint name="root"/><geom type="box" size="0.1 0.2 0.3" mass="1"/></body></worldbody></mujoco>""")
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, str(path))
    sim = tb.Simulator(world, dt=DT)
    lin = robot.kinematics.transition_jacobians(sim, inputs="torques")
    assert lin.A.shape == (12, 12) and lin.B.shape == (12, 0)
    expect = np.block([[np.eye(6), DT * np.eye(6)], [np.zeros((6, 6)), np.eye(6)]])
    np.testing.assert_allclose(lin.A, expect, rtol=0, atol=1e-8)


def test_torques_act_through_the_inverse_mass_matrix(tmp_path):
    """A URDF arm's inputs are its joints' torques (PyBullet's TORQUE_CONTROL): over one step a torque
    changes the rates by h M(q)^-1 tau, to first order in h (the substeps' q moves by O(h) and
    gravity's part is the same on both sides): B's rate rows against h M^-1 from
    ``Kinematics.mass_matrix`` (an independent route: the bodies' Jacobians) to 2 % of its largest
    entry (measured 0.45 %). The position rows are O(h^2): 10/16 h^2 M^-1 (the 4 substeps')."""
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_urdf(world, "examples/robots/arm.urdf", fixed_base=True)
    sim = tb.Simulator(world, dt=DT, joint_settings=JointSettings(method="tree"))
    sim.step(10)
    kin = robot.kinematics
    lin = kin.transition_jacobians(sim, inputs="torques")
    nv = kin.nv
    expect = DT * np.linalg.inv(kin.mass_matrix(kin.qpos(sim)))
    names = [c.name for c in kin.coordinates]
    assert lin.inputs == names
    assert np.abs(lin.B[nv:] - expect).max() < 0.02 * np.abs(expect).max()
    assert np.abs(lin.B[:nv]).max() < 2 * DT * np.abs(expect).max()


def test_the_simulation_is_left_as_it_was(tmp_path):
    """Every column steps from the one snapshot; after the call the next steps give the bits they
    give without it (the state hash after 60 steps), and the controls are back."""
    def run(call):
        _, world, robot, sim = _pendulum(tmp_path, method="gauss-seidel")
        robot.set_controls(sim, {"torque": 0.3})
        sim.step(30)
        if call:
            robot.kinematics.transition_jacobians(sim)
            assert robot.actuators["torque"].ctrl == 0.3
        sim.step(60)
        return state_hash(world)

    assert run(True) == run(False)


def test_a_body_asleep_on_the_ground_is_left_asleep_with_its_contacts(tmp_path):
    """A box resting on a plane (a free joint, contacts, asleep after 2 s): the columns step it awake
    from the snapshot, and afterwards it is asleep again with the same contacts, and the next
    steps (a push wakes it) give the bits they give without the call. A's rate rows see the
    contact: the box pressed down 1e-6 m comes back up (dvz'/dz < 0)."""
    path = tmp_path / "rest.xml"
    path.write_text("""<mujoco><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
      <body name="box" pos="0 0 0.1"><freejoint name="root"/><geom type="box" size="0.1 0.1 0.1" mass="1"/>
      </body></worldbody></mujoco>""")

    def run(call):
        world = tb.World(gravity=(0, 0, -9.81))
        robot = tb.load_mjcf(world, str(path))
        sim = tb.Simulator(world, dt=DT)
        sim.step(int(round(2.0 / DT)))
        box = robot.links["box"].index
        awake = sim.sleep.awake[: world.body_count].copy()
        contacts = sim.contacts().normal_impulse.copy()
        lin = None
        if call:
            lin = robot.kinematics.transition_jacobians(sim, inputs="torques")
            assert np.array_equal(sim.sleep.awake[: world.body_count], awake)
            assert np.array_equal(sim.contacts().normal_impulse, contacts)
        robot.links["box"].apply_impulse((0.5, 0.0, 0.0))
        sim.step(60)
        return state_hash(world), lin, awake[box]

    (h1, lin, box_awake), (h2, _, _) = run(True), run(False)
    assert not box_awake  # it was asleep when linearized
    assert h1 == h2
    assert lin.A[6 + 2, 2] < 0.0  # vz' against z: pressed in, pushed back out


def test_a_control_at_the_end_of_its_range_is_differenced_inside(tmp_path):
    """ctrl at the top of its ctrlrange: a step up would be clipped back (a zero column); the column
    is taken backwards, one-sided, and equals the centred one of a free control (O(eps) apart)."""
    _, _, robot, sim = _pendulum(tmp_path)
    free = robot.kinematics.transition_jacobians(sim).B
    robot.actuators["torque"].ctrlrange = (-1.0, 0.0)
    capped = robot.kinematics.transition_jacobians(sim).B
    np.testing.assert_allclose(capped, free, rtol=1e-5)


def test_bad_input(tmp_path):
    _, _, robot, sim = _pendulum(tmp_path)
    for kwargs, key in ((dict(eps=0.0), "eps"), (dict(eps=2.0), "eps"), (dict(eps=True), "eps"),
                        (dict(inputs="forces"), "inputs")):
        with pytest.raises(InputError) as err:
            robot.kinematics.transition_jacobians(sim, **kwargs)
        assert err.value.key == key
    world = tb.World()
    arm = tb.load_urdf(world, "examples/robots/arm.urdf", fixed_base=True)
    with pytest.raises(InputError, match="no actuators"):
        arm.kinematics.transition_jacobians(tb.Simulator(world), inputs="controls")
    with pytest.raises(InputError, match="another world"):
        arm.kinematics.transition_jacobians(sim)


def test_lqr_from_the_jacobians_holds_the_pendulum_upside_down(tmp_path):
    """What the Jacobians are for: linearized upright (an unstable equilibrium: A has an eigenvalue
    above 1), a discrete LQR gain from SciPy's Riccati solver, u = -G (x - x_top) applied before every
    step by a controller, brings the pendulum let go 0.2 rad off the top back to it (under 1e-3 rad
    and 1e-2 rad/s after 3 s), its torque falling to nothing there; without the controller it falls
    (past 1 rad in 3 s)."""
    path, _, robot, sim = _pendulum(tmp_path)
    kin = robot.kinematics
    top = np.array([np.pi])
    kin.set_state(top, np.zeros(1), sim=sim)
    lin = kin.transition_jacobians(sim)
    assert np.max(np.abs(np.linalg.eigvals(lin.A))) > 1.0
    Q, Rc = np.diag([10.0, 1.0]), np.array([[0.1]])
    P = sl.solve_discrete_are(lin.A, lin.B, Q, Rc)
    G = np.linalg.solve(Rc + lin.B.T @ P @ lin.B, lin.B.T @ P @ lin.A)
    torques = []
    angle, rate, _ = _run_lqr(path, G, top, torques)
    assert abs(angle) < 1e-3 and abs(rate) < 1e-2
    assert abs(torques[-1]) < 1e-3 * K  # at the top, held by no torque at all
    *_, fell = _run_lqr(path, None, top, [])
    assert fell > 1.0


def _run_lqr(path, G, top, torques):
    """The pendulum let go 0.2 rad off the top, under u = -G x (G None: no torque) for 3 s: (angle off
    the top, rate, the largest angle off the top on the way), rad and rad/s."""
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, str(path))
    kin = robot.kinematics
    offs = []

    def control(sim):
        # the angle off the top in (-pi, pi]: the hinge is read in (-pi, pi] before the solver counts turns
        off = np.remainder(kin.qpos(sim)[0] - top[0] + np.pi, 2 * np.pi) - np.pi
        offs.append(abs(off))
        if G is not None:
            u = float(-(G @ np.array([off, kin.qvel()[0]]))[0])
            torques.append(u)
            robot.set_controls(sim, {"torque": u})

    sim = tb.Simulator(world, dt=DT, joint_settings=JointSettings(method="tree"), controller=control)
    kin.set_state(top + 0.2, np.zeros(1), sim=sim)
    sim.step(int(round(3.0 / DT)))
    return np.remainder(kin.qpos(sim)[0] - top[0] + np.pi, 2 * np.pi) - np.pi, kin.qvel()[0], max(offs)


def test_difference_undoes_integrate(tmp_path):
    """``kin.difference(kin.integrate(q, v, h), q, h) = v`` for a free joint, a ball, a hinge and a
    slide (MuJoCo's mj_differentiatePos against mj_integratePos), rotations up to 2.5 rad, to 1e-12:
    the tangent space A's columns are taken in."""
    path = tmp_path / "mixed.xml"
    path.write_text("""<mujoco><worldbody><body name="base" pos="0 0 1"><freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.1" mass="1"/>
      <body name="a" pos="0.3 0 0"><joint name="ball" type="ball"/><geom type="sphere" size="0.05" mass="0.5"/>
        <body name="b" pos="0.2 0 0"><joint name="hinge" type="hinge" axis="0 0 1"/>
          <geom type="sphere" size="0.05" mass="0.5"/>
          <body name="c" pos="0.2 0 0"><joint name="slide" type="slide" axis="1 0 0"/>
            <geom type="sphere" size="0.05" mass="0.5"/></body></body></body></body></worldbody></mujoco>""")
    world = tb.World(gravity=(0, 0, 0))
    kin = tb.load_mjcf(world, str(path)).kinematics
    assert (kin.nq, kin.nv) == (7 + 4 + 1 + 1, 6 + 3 + 1 + 1)
    rng = np.random.default_rng(3)
    q = kin.qpos()
    for _ in range(20):
        v = rng.normal(size=kin.nv)
        v *= 2.5 / max(np.linalg.norm(v[3:6]), np.linalg.norm(v[6:9]), 1.0)  # rotations under 2.5 rad (log's range: pi)
        h = float(rng.uniform(0.1, 1.0))
        np.testing.assert_allclose(kin.difference(kin.integrate(q, v, h), q, h), v, rtol=0, atol=1e-12)


def test_the_lqr_cartpole_example_balances():
    """examples/control/lqr_cartpole.py: LQR from the linearized step (a slide and a hinge, the
    cart's motor as input) brings the cart-pole from 0.3 m off centre with its pole 0.15 rad over
    back to upright over the centre within 5 s (under 5 mm and 1e-3 rad; measured 1.0 mm and
    3.5e-4 rad, still converging), pushing within the motor's ctrlrange of 20 N (13 N); left alone
    the pole falls over (past 1 rad)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "control" / "lqr_cartpole.py"
    spec = importlib.util.spec_from_file_location("lqr_cartpole", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    _, robot, sim, pushes = example.balance()
    cart, pole = robot.kinematics.qpos(sim)
    assert abs(cart) < 5e-3 and abs(pole) < 1e-3
    assert max(abs(u) for u in pushes) <= 20.0
    _, robot, sim, _ = example.balance(gain=0)
    assert abs(robot.kinematics.qpos(sim)[1]) > 1.0
