"""tumble.envs' humanoids: Gymnasium's ``Humanoid-v5`` and ``HumanoidStandup-v5`` stepped by tumble.

Compared with: MuJoCo 4's own derived quantities on the same states (``cinert``, ``cvel``,
``subtree_com``, ``qfrc_actuator``: the observation's parts), Gymnasium's own environments
(the start drawn from a seed, the reward, termination and info of given states, the motion in
the air at a converged step) and Newton's second law (the contact forces of ``cfrc_ext``)."""

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
mujoco = pytest.importorskip("mujoco")

import tumble.envs as te  # noqa: E402

HUMANOIDS = [("Humanoid", te.Humanoid), ("HumanoidStandup", te.HumanoidStandup)]


def mujoco_env(name, timestep=None, frame_skip=None):
    """Gymnasium's own environment stepped by MuJoCo; with ``timestep``, a reference: MuJoCo's RK4
    (the file's own integrator) at that step."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(f"{name}-v5").unwrapped
    if timestep is not None:
        env.model.opt.timestep = timestep
        env.frame_skip = frame_skip
    return env


def random_state(env, rng, spread=0.2):
    """A random qpos (unit quaternion) and qvel of the humanoid around its model pose."""
    qpos = env.init_qpos + rng.normal(0, spread, len(env.init_qpos))
    qpos[3:7] /= np.linalg.norm(qpos[3:7])
    return qpos, rng.normal(0, 1, len(env.init_qvel))


@pytest.mark.parametrize("name, make", HUMANOIDS)
def test_humanoids_start_where_gymnasiums_start(name, make):
    """Same seed, same start (qpos and qvel uniform +-0.01, as drawn) and the same reset info
    (tendons' lengths and rates included): the observation equal to 1e-13 (qpos and qvel
    exactly; the derived parts are the same formulas, summed in another order), the
    actuator and contact forces 0 (MuJoCo's reset zeroes ``ctrl`` and ``cfrc_ext``)."""
    ours, theirs = make(), mujoco_env(name)
    for seed in (0, 5):
        o1, i1 = ours.reset(seed=seed)
        o2, i2 = theirs.reset(seed=seed)
        assert o1.shape == o2.shape == ours.observation_space.shape == (348,)
        assert np.array_equal(o1[:45], o2[:45])
        np.testing.assert_allclose(o1, o2, rtol=0, atol=1e-13)
        assert not o1[45 + 130 + 78:].any()
        assert i1.keys() == i2.keys()
        for key in i1:
            np.testing.assert_allclose(i1[key], i2[key], rtol=0, atol=1e-15, err_msg=key)


@pytest.mark.parametrize("name, make", HUMANOIDS)
def test_humanoid_derived_quantities_are_mujocos_on_the_same_states(name, make):
    """The observation's derived parts against MuJoCo's ``mj_forward`` on the same random states
    (30, tilted, bent, spinning): each body's ``cinert`` (inertia about the centre of mass, m d,
    m), ``cvel`` (angular velocity, velocity of its point at the centre of mass) and the centre
    of mass (``subtree_com`` of the root, Gymnasium's ``mass_center``), to 1e-12 of their scale
    (the same formulas; tumble's bodies' poses come through its own state, 1e-16 apart). The
    masses are the file's bodies' (42.116 kg), not tumble's virtual links'. A body welded into its
    parent (the feet) has its own inertia and velocity rows."""
    ours, theirs = make(), mujoco_env(name)
    ours.reset(seed=0)
    rng = np.random.default_rng(3)
    copies = ours._copies
    assert copies._file_bodies().names == [theirs.model.body(i).name for i in range(1, theirs.model.nbody)]
    assert copies._file_bodies().mass.sum() == pytest.approx(theirs.model.body_mass.sum(), rel=1e-14)
    for _ in range(30):
        qpos, qvel = random_state(ours, rng)
        ours.set_state(qpos, qvel)
        theirs.set_state(qpos, qvel)
        d = theirs.data
        np.testing.assert_allclose(copies.com_inertia()[0], d.cinert[1:], rtol=0, atol=1e-12 * np.abs(d.cinert).max())
        np.testing.assert_allclose(copies.com_velocity()[0], d.cvel[1:], rtol=0, atol=1e-12 * np.abs(d.cvel).max())
        np.testing.assert_allclose(copies.center_of_mass()[0], d.subtree_com[1], rtol=0, atol=1e-14)


@pytest.mark.parametrize("name, make", HUMANOIDS)
def test_humanoid_actuator_forces_are_mujocos(name, make):
    """``qfrc_actuator`` after a step with random controls, some past the +-0.4 control range
    (clipped, as MuJoCo's ``ctrllimited``): equal to MuJoCo's computed from the same ``ctrl``
    (gear x clipped control on each driven hinge, 0 on the free root's six rates), exactly: one
    product of the same two numbers."""
    ours, theirs = make(), mujoco_env(name)
    ours.reset(seed=0)
    theirs.reset(seed=0)
    rng = np.random.default_rng(8)
    for _ in range(5):
        action = rng.uniform(-0.6, 0.6, 17).astype(np.float32)
        obs, *_ = ours.step(action)
        theirs.data.ctrl[:] = action
        mujoco.mj_forward(theirs.model, theirs.data)
        assert np.array_equal(ours._copies.actuator_forces()[0], theirs.data.qfrc_actuator)
        assert np.array_equal(obs[45 + 130 + 78:45 + 130 + 78 + 17], theirs.data.qfrc_actuator[6:])


class _Chosen:
    """A task's ``links``: the env's own view, with chosen contact and actuator forces (the
    arithmetic test below: tumble's contacts are its own, so MuJoCo's side is given the same)."""

    def __init__(self, view, forces, actuator_forces):
        self.view, self.forces, self.actuation = view, forces, actuator_forces

    def __getattr__(self, name):
        return getattr(self.view, name)

    def external_forces(self):
        return self.forces[None]

    def actuator_forces(self):
        return self.actuation[None]


@pytest.mark.parametrize("name, make", HUMANOIDS)
def test_humanoid_rewards_terminations_and_info_are_gymnasiums(name, make):
    """The tasks' arithmetic against Gymnasium's own on the same states, forces and actions: random
    states before and after a step (some fallen below z = 1 or thrown above 2: unhealthy), random
    contact forces (up to 3000 N and N m: past the contact cost's cap of 10 now and then) and
    actions; Gymnasium's side is its environment set to each state (``set_state``), its
    ``cfrc_ext`` and ``ctrl`` set, asked its observation, reward (``_get_rew``: the centre of
    mass's speed over ``dt`` for the walk, the height over the timestep for the standup) and
    health. The observation to 1e-12 of its scale, the reward and info to 1e-6 relative (the
    control cost squared in float32 there, float64 here)."""
    ours, theirs = make(), mujoco_env(name)
    ours.reset(seed=0)
    theirs.reset(seed=0)
    rng = np.random.default_rng(4)
    unhealthy = capped = 0
    walk = name == "Humanoid"
    for k in range(30):
        before, _ = random_state(ours, rng)
        qpos, qvel = random_state(ours, rng)
        if k % 3 == 0:
            qpos[2] = rng.choice([0.5, 0.99, 2.1])
        forces = rng.uniform(-1, 1, (13, 6)) * (3000.0 if k % 4 == 0 else 300.0)
        action = rng.uniform(-0.4, 0.4, 17).astype(np.float32)
        ours.set_state(before, qvel)
        ours.remember(before[None], qvel[None], ours._copies.view)
        theirs.set_state(before, qvel)
        com_before = te_mass_center(theirs)
        ours.set_state(qpos, qvel)
        theirs.data.ctrl[:] = action
        theirs.set_state(qpos, qvel)
        theirs.data.cfrc_ext[1:] = forces
        links = _Chosen(ours._copies.view, forces, theirs.data.qfrc_actuator.copy())
        obs = ours.observe(qpos[None], qvel[None], links)
        reward, terminated, info = ours.evaluate(obs, action[None].astype(np.float64))
        expected_obs = theirs._get_obs()
        np.testing.assert_allclose(obs[0], expected_obs, rtol=0, atol=1e-12 * np.abs(expected_obs).max())
        if walk:
            velocity = (te_mass_center(theirs) - com_before) / theirs.dt
            expected_reward, reward_info = theirs._get_rew(velocity[0], action)
            healthy = theirs.is_healthy
            expected = {"x_position": qpos[0], "y_position": qpos[1], "distance_from_origin": np.linalg.norm(qpos[:2]),
                        "x_velocity": velocity[0], "y_velocity": velocity[1], **reward_info}
            capped += reward_info["reward_contact"] == -10.0
        else:
            expected_reward, reward_info = theirs._get_rew(qpos[2], action)
            healthy = True
            expected = {"x_position": qpos[0], "y_position": qpos[1],
                        "z_distance_from_origin": qpos[2] - theirs.init_qpos[2], **reward_info}
            capped += reward_info["reward_impact"] == -10.0
        expected.update(tendon_length=theirs.data.ten_length.copy(), tendon_velocity=theirs.data.ten_velocity.copy())
        unhealthy += not healthy
        assert reward[0] == pytest.approx(expected_reward, rel=1e-6)
        assert bool(terminated[0]) == (not healthy)
        assert info.keys() == expected.keys()
        for key, value in expected.items():
            np.testing.assert_allclose(info[key][0], value, rtol=1e-6, atol=1e-12, err_msg=key)
    assert capped >= 3
    assert unhealthy >= (5 if walk else 0)


def te_mass_center(env):
    """Gymnasium's ``mass_center`` of its humanoid (x, y)."""
    from gymnasium.envs.mujoco.humanoid_v5 import mass_center

    return mass_center(env.model, env.data)


def test_humanoid_in_the_air_converges_to_mujoco_rk4_at_first_order():
    """The humanoid's dynamics without contact (a free root; 17 hinges, several in one body, with
    springs, dampers and armature): lifted to z = 3 m, tilted, spinning, every hinge halfway along its range (the model's pose has the knees at 0, outside
    their range, the hips 5 degrees from it: MuJoCo's soft limits and tumble's rigid ones part
    there), 0.12 s of random controls within +-0.3 against MuJoCo's RK4
    at 1e-4 s; nothing touches (no contact in either engine), no joint comes within 0.03 rad of
    its range. Each halving of tumble's step halves the largest qpos difference (first order:
    ratios 1.7-2.3; measured at 0.003 to 0.000375 s: 2.7e-3, 1.2e-3, 6.1e-4, 3.0e-4, ratios
    2.18, 2.02, 2.03). Were a body's mass or inertia, a gear, armature, spring or damper read
    otherwise, the difference would stop shrinking."""
    env_dt = 0.03
    env = te.Humanoid()
    actions = np.random.default_rng(6).uniform(-0.3, 0.3, size=(4, 17))
    start = env.init_qpos.copy()
    start[2] = 3.0
    start[3:7] = [0.99, 0.05, -0.1, 0.02]
    start[3:7] /= np.linalg.norm(start[3:7])
    kin = env.robot.kinematics
    for c in kin.coordinates:  # every hinge halfway along its range
        if c.lower is not None:
            start[c.qpos] = 0.5 * (c.lower + c.upper)
    rate = np.random.default_rng(2).normal(0, 0.5, 23)

    def run(env):
        env.reset(seed=1)
        env.set_state(start, rate)
        out = []
        for a in actions:
            env.step(a.astype(np.float32))
            if hasattr(env, "data"):
                assert env.data.ncon == 0
                out.append(env.data.qpos.copy())
            else:
                assert len(env.sim.contacts()) == 0
                out.append(env._copies.state()[0][0].copy())
        return np.array(out)

    from tests.test_envs_runners import assert_first_order

    reference = run(mujoco_env("Humanoid", 1e-4, int(round(env_dt / 1e-4))))
    assert_first_order(reference, kin.coordinates, 0.03, run, te.Humanoid, env_dt, (0.003, 0.0015, 0.00075, 0.000375))


def test_humanoid_external_forces_obey_newtons_law_on_their_own_bodies():
    """``cfrc_ext`` by Newton's second law: over each simulator step the humanoid's linear momentum
    changes by dt (sum of its bodies' external forces - m g), to 1e-9 of m g dt, through its
    fall (landing on its feet, toppling, lying). The feet, welded to the shins (one tumble body
    each), keep their own rows: standing on them at the start, all the vertical force is on the
    feet's rows and none on the shins' (``Contacts.part_a``/``part_b``). Lying after 6 s the mean
    vertical force over a second is its weight (413.2 N) to 1e-3."""
    env = te.Humanoid(reset_noise_scale=0.0, terminate_when_unhealthy=False)
    env.reset(seed=0)
    w = env.world
    moving = np.flatnonzero(w.moving)
    weight = w.mass[moving].sum() * 9.81
    names = env._copies._file_bodies().names
    feet = [names.index("right_foot"), names.index("left_foot")]
    shins = [names.index("right_shin"), names.index("left_shin")]
    dt = env.sim.dt

    def step_and_check():
        before = (w.mass[moving, None] * w.v[moving]).sum(axis=0)
        env.sim.step(1)
        env._copies.fresh[:] = False  # stepped (``env.step``'s bookkeeping)
        after = (w.mass[moving, None] * w.v[moving]).sum(axis=0)
        forces = env._copies.external_forces()[0]
        total = forces[:, 3:].sum(axis=0) - (0.0, 0.0, weight)
        np.testing.assert_allclose((after - before) / dt, total, rtol=0, atol=1e-9 * weight)
        return forces

    forces = [step_and_check() for _ in range(100)]  # landing on its feet (at 0.15 s), standing
    vertical = np.array([f[:, 5] for f in forces])
    assert vertical[:, feet].sum() > 0.5 * weight * 100 and not vertical[:, shins].any()
    assert np.allclose(vertical.sum(axis=1), vertical[:, feet].sum(axis=1))
    for k in range(400):
        env.step(np.zeros(17, dtype=np.float32))
        if k % 40 == 39:
            step_and_check()
    lying = [step_and_check()[:, 5].sum() for _ in range(int(round(1.0 / dt)))]
    assert np.mean(lying) == pytest.approx(weight, rel=1e-3)


@pytest.mark.parametrize("name, make", HUMANOIDS)
def test_vector_humanoid_copies_equal_single_envs_bit_for_bit(name, make):
    """``ModelVectorEnv``'s copy i is the single environment seeded seed + i, bit for bit, through
    terminations (the humanoid falls below z = 1 within a second), truncations (25 steps) and
    autoresets: 3 copies in one world, each in an env of its own over one floor, their
    observations' derived parts (``cinert``, ``cvel``, actuator and contact forces) and tendon
    infos included."""
    from tests import test_envs

    venv = gym.make_vec(f"tumble/{name}-v5", num_envs=3, vectorization_mode="vector_entry_point",
                        max_episode_steps=25)
    episodes = test_envs._compare_vector_with_singles(venv, make, 3, 60, 25, 3, 17, np.random.default_rng(0))
    assert episodes >= 6
    single = make()
    single.reset(seed=11)
    venv.reset(seed=11)
    action = np.full(17, 0.1, dtype=np.float32)
    info, expected = venv.step(np.tile(action, (3, 1)))[4], single.step(action)[4]
    assert info.keys() == {k for key in expected for k in (key, "_" + key)}
    assert info["tendon_length"].shape == (3, 2) and np.array_equal(info["tendon_length"][0], expected["tendon_length"])


@pytest.mark.parametrize("make", [te.Humanoid, te.Ant])
def test_an_episode_after_others_is_a_fresh_envs_bit_for_bit(make):
    """Reproducible episodes of a free-rooted model: reset with a seed after 30 steps of another
    episode (random controls: joints turned, contacts made), the episode is a fresh
    environment's, bit for bit. Found with the humanoid: a hinge's angle was unwrapped as
    reading + wrap(angle - reading), rounded by the reading, which a reset sets to the start's
    qpos and a fresh world has at 0; the two parted at 1e-15 in the first step
    (``joint_math._coordinate_row`` now adds whole turns to the angle itself)."""
    nu = 17 if make is te.Humanoid else 8
    rng = np.random.default_rng(0)
    used = make()
    used.reset(seed=3)
    for _ in range(30):
        used.step(rng.uniform(-0.4, 0.4, nu).astype(np.float32))
    fresh = make()
    assert np.array_equal(used.reset(seed=11)[0], fresh.reset(seed=11)[0])
    for _ in range(10):
        action = rng.uniform(-0.4, 0.4, nu).astype(np.float32)
        assert np.array_equal(used.step(action)[0], fresh.step(action)[0])


def test_a_humanoid_under_random_controls_does_not_blow_up():
    """Gymnasium's humanoid under uniform random controls over their whole range, episodes ended by
    falls and reset (the benchmark's load, benchmarks/envs.py): 230 steps (3.5 s, seven
    episodes), every rate finite and under 100 rad/s. Found by the benchmark (64 copies): at
    2.871 s of this run a hip's joint read the rate its light virtual link had after the
    substep's motor torque (hundreds of rad/s, before the tree solve shares it out), its limit
    row 0.6 rad from the limit pushed, and armature carried what the sweeps left: 1e3, 1e5, 1e7
    rad/s in three substeps, then NaN. Now the biased solve of a model with armature makes the velocities consistent with
    the tree first (``joint_tree.tree_sweeps_kernel``, ``factor`` 2): measured at most 24 rad/s
    (a shin, swinging)."""
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-0.4, 0.4, (64, 17)).astype(np.float32)[7] for _ in range(230)]
    env = te.Humanoid()
    env.reset(seed=7)
    ended, fastest, episodes = False, 0.0, 0
    for action in actions:
        if ended:
            env.reset()
            ended, episodes = False, episodes + 1
            continue
        *_, terminated, truncated, _ = env.step(action)
        ended = terminated or truncated
        fastest = max(fastest, np.abs(env.world.omega).max())
    assert np.all(np.isfinite(env.world.x)) and fastest < 100.0
    assert episodes >= 5


def test_the_humanoid_fallen_and_the_ant_standing_come_to_rest():
    """With zero controls Gymnasium's humanoid falls and lies on the floor, its right arm wedged
    between its legs and the floor, an elbow on its limit (seed 0); the ant stands on its four legs.
    Both come to rest: the humanoid's largest joint rate from 9 to 12 s under 1e-6 rad/s (measured
    1.8e-13: median 1e-13; MuJoCo's same model 0.012, its soft contacts still creeping), the ant's
    largest rate falling every 5 s from 10 s on and under 1e-6 at 35 s (measured: 6.6e-5 at 10 s,
    1.3e-6 at 30 s, 3.3e-7 at 35 s; MuJoCo's 3.5e-6 at 10 s). The ant's slowest motion is a yaw of
    its torso over its four feet, the legs turning with it, which only the joints' damping takes
    out (a quarter every 5 s: the feet's contacts pivot, condim 3, no torsional friction). Before
    session 41's friction change (sliding friction opposite the slip) the landing left that motion
    unexcited: 1e-11 rad/s at 10 s; the landing now settles the feet a little differently.

    Before session 35 neither did: the contacts were solved with each link's own mass while the
    joints' tree saw the whole mechanism and its armature, and the two solves, one pass each a
    substep, settled into a cycle (the ant at 0.03-0.05 rad/s, the humanoid at 0.14); with the
    contacts solved through the tree (contact_tree) the humanoid still moved at 0.11, its elbow
    bouncing on a limit pushed back rigidly (the tree's 1/h bias: 4e-4 rad past it, then 5e-4 apart,
    each step); its limits are now solved through the tree too, and pushed back at Box2D's joint
    softness (JointSettings.limit_hertz)."""
    env = gym.make("tumble/Humanoid-v5", terminate_when_unhealthy=False, max_episode_steps=10_000)
    env.reset(seed=0)
    rates = []
    for k in range(800):  # 12 s at 0.015 s a step
        obs = env.step(np.zeros(17))[0]
        if (k + 1) * 0.015 > 9.0:
            rates.append(np.abs(obs[28:45]).max())  # the hinges' rates (qvel[6:])
    assert obs[0] < 0.2  # lying
    assert max(rates) < 1e-6
    env = gym.make("tumble/Ant-v5")
    env.reset(seed=0)
    ant_rates = []
    for k in range(3500):  # 35 s at 0.01 s
        obs = env.step(np.zeros(8))[0]
        if (k + 1) % 500 == 0:
            ant_rates.append(np.abs(obs[13:27]).max())
    assert obs[0] > 0.3  # standing
    assert all(later < earlier for earlier, later in zip(ant_rates[1:], ant_rates[2:]))  # dying away from 10 s on
    assert ant_rates[-1] < 1e-6
