"""A robot's joint-space kinematics and dynamics (``robot.kinematics``, tumble.kinematics) against
MuJoCo and PyBullet on the same files, against themselves by independent routes, and against
tumble's own maximal-coordinate simulation.

References and why each tolerance is what it is:
- MuJoCo's ``mj_jac``, ``mj_fullM``, ``mj_rne`` (+ armature x qacc: its mass matrix has the
  armature on the diagonal, its ``mj_rne`` not) on an MJCF model compiled by MuJoCo from the same
  file, and PyBullet's ``calculateJacobian``, ``calculateMassMatrix``, ``calculateInverseDynamics``
  on its Kuka arm: the same mathematics in double precision by other code, so equal to rounding
  (1e-10 absolute on entries of order 1-10; measured 1e-15).
- Finite differences of the forward kinematics (central, step 1e-6: truncation ~1e-12, rounding
  ~1e-10) for the Jacobian; the mass matrix summed from Jacobians against the inverse dynamics'
  columns (two routes through different code: rounding).
- The simulation: SciPy's DOP853 (rtol 1e-11) of qdd = M^-1 (tau - c) against tumble's exact tree
  solve stepping the bodies; tumble's step is first order, so its error at dt is bounded and
  halves with dt.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tumble as tb
from tumble.math3d import matrix_to_quat
from tumble.solver.joints import ACCURATE

mujoco = pytest.importorskip("mujoco")

ARM = "examples/robots/arm.urdf"

# A free base, a hinge off the body's origin, a slide, a ball, a hinge under the ball, armature,
# and a welded body (merged in tumble): every coordinate kind in MuJoCo's layout.
MODEL = """
<mujoco model="kinds">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="torso" pos="0.1 -0.2 1.5" euler="10 -20 30">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" density="1000"/>
      <body name="upper" pos="0.2 0 0" euler="0 0 20">
        <joint name="hip" type="hinge" axis="0 1 0.3" pos="0.02 0 0.01" armature="0.3"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 -0.2" size="0.04"/>
        <body name="lower" pos="0.3 0 -0.2">
          <joint name="slide" type="slide" axis="1 0.2 0" armature="0.5"/>
          <geom type="box" size="0.05 0.04 0.1" pos="0 0 -0.1" density="2000"/>
          <body name="hand" pos="0 0 -0.25" quat="0.9 0.1 0.2 0.3">
            <joint name="wrist" type="ball"/>
            <inertial pos="0.01 0.02 -0.05" quat="0.8 0.2 0.4 0.1" mass="0.7" diaginertia="0.002 0.003 0.004"/>
            <body name="finger" pos="0.05 0 -0.1">
              <joint name="knuckle" type="hinge" axis="1 0 0" pos="0 0.01 0"/>
              <geom type="sphere" size="0.03" pos="0.02 0 -0.03"/>
              <body name="nail" pos="0 0 -0.05"><geom type="box" size="0.01 0.01 0.01"/></body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _random_qpos(kin, rng):
    q = np.zeros(kin.nq)
    for c in kin.coordinates:
        if c.kind == "floating":
            quat = rng.normal(size=4)
            q[c.qpos] = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat)])
        elif c.kind == "spherical":
            quat = rng.normal(size=4)
            q[c.qpos] = quat / np.linalg.norm(quat)
        else:
            q[c.qpos] = rng.uniform(-1.0, 1.0)
    return q


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("kin") / "kinds.xml"
    path.write_text(MODEL)
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    m = mujoco.MjModel.from_xml_path(str(path))
    return robot, m


def test_coordinates_follow_mujocos_layout(model):
    robot, m = model
    kin = robot.kinematics
    assert (kin.nq, kin.nv) == (m.nq, m.nv) == (7 + 1 + 1 + 4 + 1, 6 + 1 + 1 + 3 + 1)
    assert [c.name for c in kin.coordinates] == [m.joint(i).name for i in range(m.njnt)]
    for c in kin.coordinates:
        j = m.joint(c.name)
        assert (c.qpos.start, c.qvel.start) == (j.qposadr[0], j.dofadr[0])
    assert kin.dof_names[:7] == [f"root[{k}]" for k in range(6)] + ["hip"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jacobians_mass_matrix_and_inverse_dynamics_equal_mujocos(model, seed):
    """The free joint's conventions (linear world, angular in the body frame), the ball's (angular
    in the child frame), the hinge off its body's origin, the slide's Coriolis term and armature
    all as MuJoCo computes them on the same file; the centres of mass of the model and of a
    subtree with their Jacobians (subtree_com, mj_jacSubtreeCom)."""
    robot, m = model
    kin = robot.kinematics
    rng = np.random.default_rng(seed)
    q, qd, qdd = _random_qpos(kin, rng), rng.normal(size=m.nv), rng.normal(size=m.nv)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = q, qd
    mujoco.mj_forward(m, d)
    d.qacc[:] = qdd
    frames = kin.forward_kinematics(q)
    for b in range(1, m.nbody):
        name = m.body(b).name
        if name == "nail":  # welded: part of the finger's body in tumble (its frame checked through the finger)
            continue
        o, R = frames[name]
        # the link frame: MuJoCo's body frame moved to the joint's anchor
        anchor = m.jnt_pos[m.body_jntadr[b]] if m.body_jntnum[b] else np.zeros(3)
        np.testing.assert_allclose(R, d.xmat[b].reshape(3, 3), atol=1e-12, err_msg=name)
        np.testing.assert_allclose(o, d.xpos[b] + R @ anchor, atol=1e-12, err_msg=name)
        for p in (d.xipos[b].copy(), d.xpos[b] + rng.normal(size=3) * 0.3):
            jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, jacp, jacr, p, b)
            J = kin.jacobian(name, R.T @ (p - o), q)
            np.testing.assert_allclose(J[0:3], jacp, atol=1e-10, err_msg=name)
            np.testing.assert_allclose(J[3:6], jacr, atol=1e-10, err_msg=name)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    np.testing.assert_allclose(kin.mass_matrix(q), M, atol=1e-10)
    # the centre of mass of the whole model and of the hand's subtree, and their Jacobians
    for body in ("torso", "hand"):
        c, Jc = kin.center_of_mass(q, None if body == "torso" else body)
        b = m.body(body).id
        np.testing.assert_allclose(c, d.subtree_com[b], atol=1e-10, err_msg=body)
        jac = np.zeros((3, m.nv))
        mujoco.mj_jacSubtreeCom(m, d, jac, b)
        np.testing.assert_allclose(Jc, jac, atol=1e-10, err_msg=body)
    rne = np.zeros(m.nv)
    mujoco.mj_rne(m, d, 1, rne)
    np.testing.assert_allclose(kin.inverse_dynamics(qdd, q, qd), rne + m.dof_armature * qdd, atol=1e-10)
    np.testing.assert_allclose(kin.bias_forces(q, qd), d.qfrc_bias, atol=1e-10)


def test_kuka_equals_pybullet():
    """PyBullet's own arm (7 hinges, fixed base): its Jacobian of a point given in the link frame,
    its mass matrix and its inverse dynamics."""
    p = pytest.importorskip("pybullet")
    import os

    import pybullet_data

    path = os.path.join(pybullet_data.getDataPath(), "kuka_iiwa/model.urdf")
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_urdf(world, path, fixed_base=True)
    kin = robot.kinematics
    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=client)
        uid = p.loadURDF(path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
        links = [p.getJointInfo(uid, i, physicsClientId=client)[12].decode() for i in range(kin.nv)]
        rng = np.random.default_rng(3)
        for _ in range(3):
            q, qd, qdd = rng.uniform(-1.5, 1.5, kin.nv), rng.normal(size=kin.nv), rng.normal(size=kin.nv)
            M = np.array(p.calculateMassMatrix(uid, list(q), physicsClientId=client))
            np.testing.assert_allclose(kin.mass_matrix(q), M, atol=1e-10)
            tau = p.calculateInverseDynamics(uid, list(q), list(qd), list(qdd), physicsClientId=client)
            np.testing.assert_allclose(kin.inverse_dynamics(qdd, q, qd), tau, atol=1e-10)
            for i, link in enumerate(links):
                local = rng.uniform(-0.1, 0.1, 3)
                jt, jr = p.calculateJacobian(uid, i, list(local), list(q), [0.0] * kin.nv, [0.0] * kin.nv,
                                             physicsClientId=client)
                J = kin.jacobian(link, local, q)
                np.testing.assert_allclose(J[0:3], jt, atol=1e-10, err_msg=link)
                np.testing.assert_allclose(J[3:6], jr, atol=1e-10, err_msg=link)
    finally:
        p.disconnect(client)


def _free_arm(tmp_path):
    text = Path(ARM).read_text().replace('<link name="base">', '<link name="base">\n    <inertial><mass value="3"/>'
                                    '<inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0.001" ixz="0" iyz="0"/></inertial>')
    path = tmp_path / "free_arm.urdf"
    path.write_text(text)
    world = tb.World(gravity=(0, 0, -9.81))
    return tb.load_urdf(world, path, position=(0.3, -0.1, 1.0), euler_deg=(10, 20, 30))


def test_jacobian_is_the_derivative_of_forward_kinematics(model, tmp_path):
    """J qd = d/dt of the point's position and of the link's orientation along q(t) = q (+) qd t
    (central differences of ``forward_kinematics`` through ``integrate``), on the MJCF model (ball,
    free joint) and on a URDF arm with a free base and a merged link; and ``point_acceleration`` at
    qdd = 0 is d/dt (J qd) = Jdot qd along that motion (the rates held: a ball's and a free joint's
    body-frame rates are constant along ``integrate``'s exponential map)."""
    for robot in (model[0], _free_arm(tmp_path)):
        kin = robot.kinematics
        rng = np.random.default_rng(4)
        q, qd = _random_qpos(kin, rng), rng.normal(size=kin.nv)
        h = 1e-6
        ahead, behind = kin.forward_kinematics(kin.integrate(q, qd, h)), kin.forward_kinematics(kin.integrate(q, qd, -h))
        for link in kin.links:
            if robot.owners[link] != link:
                continue
            local = rng.normal(size=3) * 0.2
            J = kin.jacobian(link, local, q)
            (oa, Ra), (ob, Rb) = ahead[link], behind[link]
            velocity = ((oa + Ra @ local) - (ob + Rb @ local)) / (2 * h)
            dR = (Ra - Rb) / (2 * h)
            R = kin.forward_kinematics(q)[link][1]
            W = dR @ R.T  # [omega]x
            omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
            np.testing.assert_allclose(J[0:3] @ qd, velocity, atol=1e-8, err_msg=link)
            np.testing.assert_allclose(J[3:6] @ qd, omega, atol=1e-8, err_msg=link)
            # and the point's acceleration at qdd = 0 is d/dt (J qd) along the same motion (Jdot qd)
            acc, alpha = kin.point_acceleration(link, local, None, q, qd)
            Ja = kin.jacobian(link, local, kin.integrate(q, qd, h))
            Jb = kin.jacobian(link, local, kin.integrate(q, qd, -h))
            np.testing.assert_allclose(acc, (Ja[0:3] - Jb[0:3]) @ qd / (2 * h), atol=1e-7, err_msg=link)
            np.testing.assert_allclose(alpha, (Ja[3:6] - Jb[3:6]) @ qd / (2 * h), atol=1e-7, err_msg=link)


def test_mass_matrix_two_routes_and_the_kinetic_energy(model, tmp_path):
    """M from the bodies' Jacobians equals the inverse dynamics' columns without gravity and rates
    (M e_k = tau(qdd = e_k)); 1/2 qd^T M qd (less the armature, which has no body) equals the
    world's kinetic energy of the bodies once they move as J qd says, and every link's point
    velocity ``link_velocity`` reads from them is J qd."""
    for robot in (model[0], _free_arm(tmp_path)):
        kin = robot.kinematics
        rng = np.random.default_rng(5)
        q = _random_qpos(kin, rng)
        M = kin.mass_matrix(q)
        columns = np.array([kin.inverse_dynamics(e, q, np.zeros(kin.nv), gravity=(0, 0, 0)) for e in np.eye(kin.nv)]).T
        np.testing.assert_allclose(M, columns, atol=1e-12)
        assert np.allclose(M, M.T, atol=1e-14) and np.all(np.linalg.eigvalsh(M) > 0)
        # put the world at q, moving at qd, then read both back and compare the energy
        world = robot.world
        qd = rng.normal(size=kin.nv)
        _set_state(robot, q, qd)
        _assert_same_qpos(kin, kin.qpos(), q)
        np.testing.assert_allclose(kin.qvel(), qd, atol=1e-12)
        armature = np.array([c.armature for c in kin.coordinates for _ in range(c.qvel.stop - c.qvel.start)])
        energy = 0.5 * qd @ (M - np.diag(armature)) @ qd
        assert energy == pytest.approx(world.kinetic_energy(), rel=1e-12)
        # each link's point velocity read from the bodies (link_velocity) is the Jacobian times the rates
        for link in kin.links:
            v, w = robot.link_velocity(link, (0.05, -0.02, 0.1))
            J = kin.jacobian(link, (0.05, -0.02, 0.1), q)
            np.testing.assert_allclose(v, J[0:3] @ qd, atol=1e-12, err_msg=link)
            np.testing.assert_allclose(w, J[3:6] @ qd, atol=1e-12, err_msg=link)


def _assert_same_qpos(kin, got, expected):
    """Equal positions, a quaternion equal up to its sign (q and -q are one rotation)."""
    for c in kin.coordinates:
        g, e = got[c.qpos], expected[c.qpos]
        if c.kind == "floating":
            np.testing.assert_allclose(g[0:3], e[0:3], atol=1e-12)
            g, e = g[3:7], e[3:7]
        if c.kind in ("floating", "spherical") and g @ e < 0:
            g = -g
        np.testing.assert_allclose(g, e, atol=1e-12, err_msg=c.name)


def _set_state(robot, q, qd):
    """Bodies at the frames of q, each moving as the Jacobian at its centre of mass says."""
    robot.kinematics.set_state(q, qd)


@pytest.mark.parametrize("free_base", [False, True])
def test_simulated_arm_follows_the_reduced_equations(tmp_path, free_base):
    """The arm of examples/robot_arm.toml (damping and limits removed) from a bent pose under gravity (fixed
    base) or floating without gravity (free base), with constant joint torques, stepped by tumble
    (bodies and joints, the exact tree solve) against DOP853 of qdd = M^-1 (tau - c) from
    ``robot.kinematics``: within 2e-3 rad (fixed) / 2e-3 rad and 2e-4 m (free) at dt 1/960 over
    0.5 s, and the error about halves at dt 1/1920 (first order, as the step is)."""
    # no damping and no limits (continuous joints): the arm swings through 2 rad, further than its range
    text = Path(ARM).read_text().replace('<dynamics damping="0.5"/>', "").replace('<dynamics damping="0.2"/>', "")
    text = text.replace('type="revolute"', 'type="continuous"')
    if free_base:
        text = text.replace('<link name="base">', '<link name="base">\n    <inertial><mass value="3"/>'
                            '<inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>')
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    torques = {"yaw": 0.3, "shoulder": 2.0, "elbow": -1.0}
    start = {"yaw": 0.2, "shoulder": 0.7, "elbow": -0.9}
    gravity = (0.0, 0.0, 0.0) if free_base else (0.0, 0.0, -9.81)
    duration = 0.5

    def simulate(dt):
        world = tb.World(gravity=gravity)
        robot = tb.load_urdf(world, path, joint_positions=start, position=(0, 0, 1))
        sim = tb.Simulator(world, dt=dt, joint_settings=ACCURATE)
        for joint, value in torques.items():
            robot.set_joint_torque(sim, joint, value)
        sim.run(duration, frame_rate=2)
        return robot.kinematics.qpos(sim), robot

    q_coarse, robot = simulate(1 / 960)
    q_fine, _ = simulate(1 / 1920)
    kin = robot.kinematics
    tau = np.zeros(kin.nv)
    for joint, value in torques.items():
        tau[kin.by_name[joint].qvel] = value
    world0 = tb.World(gravity=gravity)
    kin0 = tb.load_urdf(world0, path, joint_positions=start, position=(0, 0, 1)).kinematics
    q0 = kin0.qpos()

    def rhs(t, y):
        q, qd = y[:kin.nq], y[kin.nq:]
        if free_base:  # the quaternion's rate from the body-frame angular velocity, renormalised by the solver's accuracy
            qdot = np.zeros(kin.nq)
            qdot[0:3] = qd[0:3]
            w, x, yq, z = q[3:7]
            ox, oy, oz = qd[3:6]
            qdot[3:7] = 0.5 * np.array([-x * ox - yq * oy - z * oz, w * ox + yq * oz - z * oy,
                                        w * oy + z * ox - x * oz, w * oz + x * oy - yq * ox])
            qdot[7:] = qd[6:]
        else:
            qdot = qd
        return np.concatenate([qdot, kin0.forward_dynamics(tau, q, qd)])

    sol = solve_ivp(rhs, (0, duration), np.concatenate([q0, np.zeros(kin.nv)]), method="DOP853", rtol=1e-11,
                    atol=1e-12)
    reference = sol.y[:kin.nq, -1]
    hinges = [kin.by_name[j].qpos.start for j in torques]
    err_coarse = np.abs(q_coarse[hinges] - reference[hinges]).max()
    err_fine = np.abs(q_fine[hinges] - reference[hinges]).max()
    assert err_coarse < 2e-3
    assert err_fine < 0.6 * err_coarse  # first order: about half
    if free_base:
        base_coarse = np.abs(q_coarse[0:3] - reference[0:3]).max()
        assert base_coarse < 2e-4
        assert np.abs(q_fine[0:3] - reference[0:3]).max() < 0.6 * base_coarse


def test_qpos_counts_whole_turns_as_the_joint_readings_do():
    """A turret driven round past pi: ``qpos(sim)`` unwraps to the joint reading; without the sim
    the angle is in (-pi, pi]."""
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_urdf(world, ARM)
    sim = tb.Simulator(world)
    robot.set_motor(sim, "yaw", 8.0, 50.0)
    sim.run(1.0, frame_rate=4)
    kin = robot.kinematics
    reading = robot.joint_states(sim)["yaw"][0]
    assert reading > 2 * math.pi
    assert kin.qpos(sim)[kin.by_name["yaw"].qpos][0] == pytest.approx(reading, abs=1e-6)
    wrapped = kin.qpos()[kin.by_name["yaw"].qpos][0]
    assert -math.pi < wrapped <= math.pi
    assert math.remainder(wrapped - reading, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_inverse_kinematics_reaches_targets_within_the_limits():
    """Targets made by the forward kinematics of random joint positions within the limits (so each
    is reachable): the hand's centre reaches every one from q = 0 (straight up: a singular pose) to
    1e-6 m, with up to 3 restarts, the limits kept,
    and the hand put there by ``reset_joint_positions`` is there in the world; a point out of
    reach returns the nearest the arm gets, not converged."""
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_urdf(world, ARM)
    kin = robot.kinematics
    rng = np.random.default_rng(6)
    for _ in range(10):
        target_q = np.array([rng.uniform(-math.pi, math.pi) if c.lower is None else rng.uniform(c.lower, c.upper)
                             for c in kin.coordinates])
        o, _R = kin.forward_kinematics(target_q)["hand"]
        sol = kin.inverse_kinematics("hand", o, qpos=np.zeros(kin.nq), restarts=3)
        assert sol.converged and sol.position_error <= 1e-6
        for c in kin.coordinates:
            if c.lower is not None:
                assert c.lower <= sol.qpos[c.qpos][0] <= c.upper
        robot.reset_joint_positions(None, kin.positions(sol.qpos))
        np.testing.assert_allclose(robot.link_pose("hand")[0], o, atol=1e-6)
    far = kin.inverse_kinematics("hand", (3.0, 0.0, 0.5), qpos=np.zeros(kin.nq))
    assert not far.converged
    # the nearest: the arm straight from the shoulder (0.2 m up) towards the target, 0.6 + 0.5 m long
    assert far.position_error == pytest.approx(np.linalg.norm([3.0, 0.0, 0.5 - 0.2]) - (0.6 + 0.5), abs=1e-3)


def test_inverse_kinematics_with_orientation_on_the_kuka_arm():
    """Six-dimensional targets (position and orientation of the last link) for PyBullet's 7-joint
    Kuka arm, each reachable: all reached to 1e-6 m and 1e-6 rad with restarts; the
    orientation given as a quaternion or a matrix gives the same answer."""
    pytest.importorskip("pybullet")
    import os

    import pybullet_data

    world = tb.World()
    robot = tb.load_urdf(world, os.path.join(pybullet_data.getDataPath(), "kuka_iiwa/model.urdf"), fixed_base=True)
    kin = robot.kinematics
    rng = np.random.default_rng(7)
    for _ in range(10):
        target_q = np.array([rng.uniform(c.lower, c.upper) for c in kin.coordinates])
        o, R = kin.forward_kinematics(target_q)["lbr_iiwa_link_7"]
        sol = kin.inverse_kinematics("lbr_iiwa_link_7", o, orientation=R, qpos=np.zeros(kin.nq), restarts=5)
        assert sol.converged, (sol.position_error, sol.angle_error)
        o2, R2 = kin.forward_kinematics(sol.qpos)["lbr_iiwa_link_7"]
        assert np.linalg.norm(o2 - o) <= 1e-6
        assert np.linalg.norm(R2 - R) <= 2e-6
    quat = matrix_to_quat(np.ascontiguousarray(R))
    again = kin.inverse_kinematics("lbr_iiwa_link_7", o, orientation=quat, qpos=np.zeros(kin.nq), restarts=5)
    np.testing.assert_allclose(again.qpos, sol.qpos, atol=1e-12)


@pytest.mark.parametrize("call, key", [
    (lambda k: k.jacobian("nope"), "link"),
    (lambda k: k.jacobian("upper_arm", qpos=np.zeros(2)), "qpos"),
    (lambda k: k.mass_matrix(np.full(3, np.nan)), "qpos"),
    (lambda k: k.inverse_dynamics(np.zeros(4)), "qacc"),
    (lambda k: k.inverse_kinematics("hand", (np.inf, 0, 0)), "position"),
    (lambda k: k.inverse_kinematics("hand", (0, 0, 1), orientation=(0, 0, 0, 0)), "orientation"),
])
def test_bad_arguments_are_one_line(call, key):
    world = tb.World()
    kin = tb.load_urdf(world, ARM).kinematics
    with pytest.raises(tb.InputError) as err:
        call(kin)
    assert err.value.key == key and "\n" not in str(err.value)


def test_computed_torque_control_tracks_a_trajectory():
    """A controller that applies the inverse dynamics of the planned acceleration plus a PD
    correction (computed-torque control: Craig, Introduction to Robotics, sec. 10.6), the joints'
    viscous damping added back, makes the arm of examples/robot_arm.toml (limits kept, not
    reached; the exact tree solve) follow q(t) = q0 + A sin(2 pi f t) for 2 s from the plan's
    state. What is left is the step's own first-order error: 6.8e-3 rad at dt 1/240 (bound 1e-2),
    a quarter of it at 1/960 (1.7e-3; bound 0.35 of it). The same PD gains on gravity and
    damping compensation alone, M's diagonal mean for the inertia (no coupling, no Coriolis terms),
    miss by 20x as much (0.135 rad; bound 10x): the inverse dynamics is what the bodies do."""
    amplitude = np.array([1.0, 0.6, 0.8])
    centre = np.array([0.0, 0.5, -1.0])
    omega = 2 * math.pi * 0.5
    damping = np.array([0.0, 0.5, 0.2])  # arm.urdf's <dynamics damping>
    kp, kd = 100.0, 20.0

    def plan(t):
        return (centre + amplitude * math.sin(omega * t), amplitude * omega * math.cos(omega * t),
                -amplitude * omega ** 2 * math.sin(omega * t))

    def run(full, dt):
        world = tb.World(gravity=(0, 0, -9.81))
        robot = tb.load_urdf(world, ARM)
        kin = robot.kinematics
        _set_state(robot, plan(0)[0], plan(0)[1])  # on the plan, at its velocity
        names = [c.name for c in kin.coordinates]
        worst = [0.0]

        def controller(sim):
            q, qd = kin.qpos(sim), kin.qvel()
            q_ref, qd_ref, qdd_ref = plan(sim.world.t)
            worst[0] = max(worst[0], float(np.abs(q - q_ref).max()))
            command = qdd_ref + kp * (q_ref - q) + kd * (qd_ref - qd)
            if full:
                tau = kin.inverse_dynamics(command, q, qd) + damping * qd
            else:
                inertia = np.diag(kin.mass_matrix(q)).mean()
                tau = kin.bias_forces(q, np.zeros(kin.nv)) + damping * qd + inertia * command
            for name, value in zip(names, tau):
                robot.set_joint_torque(sim, name, float(value))

        sim = tb.Simulator(world, dt=dt, joint_settings=ACCURATE, controller=controller)
        sim.run(2.0, frame_rate=4)
        return worst[0]

    tracked = run(True, 1 / 240)
    assert tracked < 1e-2
    assert run(True, 1 / 960) < 0.35 * tracked
    assert run(False, 1 / 240) > 10 * tracked


SITES = """
<mujoco model="sites">
  <compiler angle="radian"/>
  <default><site size="0.01"/><default class="tip"><site pos="0 0 -0.3"/></default></default>
  <worldbody>
    <site name="origin" pos="0.2 0.1 0" euler="0.3 0.1 0"/>
    <camera name="overview" pos="2 -1 1.5" xyaxes="0.447 0.894 0 -0.3 0.15 0.94" fovy="50"/>
    <body name="arm" pos="0 0 1.2" euler="0.1 0.2 0.3">
      <joint name="shoulder" type="hinge" axis="0 1 0.2" pos="0.02 0 0.03"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
      <site name="elbow_mark" class="tip" quat="0.9 0.1 0.3 0.2"/>
      <body name="fore" pos="0 0 -0.4">
        <joint name="slide" type="slide" axis="0.3 0 1" pos="0 0.01 0"/>
        <camera name="chase" mode="track" pos="0.5 -1 0.2" xyaxes="1 0.5 0 0 0 1"/>
        <geom type="box" size="0.03 0.03 0.15" pos="0 0 -0.15"/>
        <body name="hand" pos="0 0 -0.3" euler="0 0.4 0">
          <geom type="sphere" size="0.05"/>
          <site name="grip" pos="0.05 0 -0.02" zaxis="1 0 0.2"/>
          <camera name="wrist" pos="0 0.03 -0.05" euler="0.2 -0.1 0.3" fovy="70" resolution="64 48"/>
          <camera name="follow" mode="trackcom" pos="0 -1 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_sites_and_cameras_sit_where_mujoco_puts_them(tmp_path):
    """Sites (on a body with a joint off its origin, on a welded body merged into its parent, on the
    worldbody; a default class's pos) and fixed cameras (orientation forms, fovy, resolution) at
    random joint positions: their frames equal MuJoCo's site_xpos/xmat and cam_xpos/xmat (MuJoCo's
    camera looks along its -z with y up: tumble's axes are x, -y, -z of it) to 1e-12, and a site's
    Jacobian ``jacobian(link, position)`` equals ``mj_jacSite``; so do the tracking cameras
    (``track`` on a body whose joint is off its origin, ``trackcom`` on the welded hand's subtree),
    which follow without turning."""
    path = tmp_path / "sites.xml"
    path.write_text(SITES)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    assert set(robot.sites) == {"origin", "elbow_mark", "grip"}
    assert set(robot.cameras) == {"overview", "wrist", "follow", "chase"}
    assert (robot.cameras["wrist"].width, robot.cameras["wrist"].height) == (64, 48)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    kin = robot.kinematics
    rng = np.random.default_rng(8)
    for _ in range(3):
        q = rng.uniform(-0.8, 0.8, 2)
        robot.reset_joint_positions(None, {"shoulder": q[0], "slide": q[1] * 0.2})
        d.qpos[:] = (q[0], q[1] * 0.2)
        mujoco.mj_forward(m, d)
        for name in robot.sites:
            o, R = robot.site_pose(name)
            np.testing.assert_allclose(o, d.site(name).xpos, atol=1e-12, err_msg=name)
            np.testing.assert_allclose(R, d.site(name).xmat.reshape(3, 3), atol=1e-12, err_msg=name)
            link, p, _R = robot.sites[name]
            if link in kin.index:
                jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
                mujoco.mj_jacSite(m, d, jacp, jacr, m.site(name).id)
                J = kin.jacobian(link, p)
                np.testing.assert_allclose(J[0:3], jacp, atol=1e-12, err_msg=name)
                np.testing.assert_allclose(J[3:6], jacr, atol=1e-12, err_msg=name)
        for name, cam in robot.cameras.items():
            centre, axes = cam.pose(world)
            np.testing.assert_allclose(centre, d.cam(name).xpos, atol=1e-12, err_msg=name)
            np.testing.assert_allclose(axes, d.cam(name).xmat.reshape(3, 3) @ np.diag([1.0, -1.0, -1.0]), atol=1e-12,
                                       err_msg=name)
            assert cam.fov_deg == pytest.approx(m.cam(name).fovy[0])
    img = robot.cameras["overview"].capture(world)
    assert (img.body >= 0).any()
    with pytest.raises(tb.InputError):
        robot.site_pose("nope")


def test_fixed_links_merged_or_kept_give_the_same_dynamics():
    """The arm's hand on a fixed joint, merged into the forearm's body (the default) or kept as a
    body of its own on a FixedJoint: the same coordinates, mass matrix and inverse dynamics (the
    merge combines masses and inertias exactly: 1e-12), the same hand Jacobian."""
    rng = np.random.default_rng(11)
    merged = tb.load_urdf(tb.World(gravity=(0, 0, -9.81)), ARM).kinematics
    kept = tb.load_urdf(tb.World(gravity=(0, 0, -9.81)), ARM, merge_fixed=False).kinematics
    assert kept.dof_names == merged.dof_names and len(kept.body_link) == len(merged.body_link) + 1
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1, 1, 3), rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(kept.mass_matrix(q), merged.mass_matrix(q), atol=1e-12)
        np.testing.assert_allclose(kept.inverse_dynamics(qdd, q, qd), merged.inverse_dynamics(qdd, q, qd), atol=1e-12)
        np.testing.assert_allclose(kept.jacobian("hand", (0.01, 0.02, 0.03), q),
                                   merged.jacobian("hand", (0.01, 0.02, 0.03), q), atol=1e-12)
