"""tumble.envs' runners: Gymnasium's ``HalfCheetah-v5``, ``Hopper-v5`` and ``Walker2d-v5`` stepped by tumble.

Compared with: Gymnasium's own environments stepped by MuJoCo on the same model files (the start
drawn from a seed, the observation, reward, termination and info of a given state, the motion in
the air at a converged step), and statics (a cheetah at rest stands on contacts that carry its
weight)."""

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import tumble as tb  # noqa: E402
import tumble.envs as te  # noqa: E402

RUNNERS = [("HalfCheetah", te.HalfCheetah), ("Hopper", te.Hopper), ("Walker2d", te.Walker2d)]
EVERY = RUNNERS + [("Ant", te.Ant)]
# and Gymnasium's humanoids (tests/test_envs_humanoid.py), for the API's checks
CHECKED = EVERY + [("Humanoid", te.Humanoid), ("HumanoidStandup", te.HumanoidStandup)]


def mujoco_runner(name, timestep=None, frame_skip=None):
    """Gymnasium's own runner stepped by MuJoCo; with ``timestep``, a reference: MuJoCo's RK4 at
    that step (the cheetah's file leaves MuJoCo's semi-implicit Euler on)."""
    mujoco = pytest.importorskip("mujoco")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # MuJoCo's deprecation of settotalmass (the cheetah's file)
        env = gym.make(f"{name}-v5").unwrapped
    if timestep is not None:
        env.model.opt.timestep = timestep
        env.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        env.frame_skip = frame_skip
    return env


@pytest.mark.parametrize("name, make", RUNNERS)
def test_runners_start_where_gymnasiums_start(name, make):
    """Same seed, same start (qpos uniform, qvel uniform or, for the cheetah, normal, drawn from the
    env's generator as Gymnasium draws them) and the same reset info. Exact: the same numbers pass
    through no arithmetic but one subtraction."""
    ours, theirs = make(), mujoco_runner(name)
    for seed in (0, 5, 999):
        o1, i1 = ours.reset(seed=seed)
        o2, i2 = theirs.reset(seed=seed)
        assert o1.shape == o2.shape == ours.observation_space.shape
        assert np.array_equal(o1, o2)
        assert i1.keys() == i2.keys() and all(i1[k] == i2[k] for k in i1)


@pytest.mark.parametrize("name, make", RUNNERS)
def test_runner_rewards_terminations_and_info_are_gymnasiums(name, make):
    """The task's arithmetic against Gymnasium's own on the same states: random states before and
    after a step (some unhealthy: the hopper and walker fallen, tilted, too high, the hopper's
    rates past 100), random actions; Gymnasium's side is its environment set to the state after
    (``set_state``) and asked its observation (``_get_obs``), reward (``_get_rew`` of the x speed
    over ``dt``) and health (``is_healthy``). Equal to 1e-6 relative: Gymnasium squares the float32
    action in float32 (the control cost), tumble in float64; everything else is the same formula."""
    ours, theirs = make(), mujoco_runner(name)
    ours.reset(seed=0)
    theirs.reset(seed=0)
    rng = np.random.default_rng(4)
    nq, nv = len(ours.init_qpos), len(ours.init_qvel)
    unhealthy = 0
    for k in range(40):
        before = ours.init_qpos + rng.normal(0, 0.3, nq)
        qpos = before + rng.normal(0, 0.1, nq)
        qvel = rng.normal(0, 4, nv)
        if k % 4 == 1:
            qpos[1] = rng.choice([0.5, 2.5, 0.79])
        if k % 4 == 2:
            qpos[2] = rng.choice([-1.2, 0.3, 1.1])
        if k % 8 == 3:
            qvel[3] = 150.0
        action = rng.uniform(-1, 1, len(ours.actuators)).astype(np.float32)
        ours.remember(before[None], qvel[None])
        obs = ours.observe(qpos[None], qvel[None])
        reward, terminated, info = ours.evaluate(obs, action[None].astype(np.float64))
        theirs.set_state(qpos, qvel)
        expected_obs = theirs._get_obs()
        x_velocity = (qpos[0] - before[0]) / theirs.dt
        expected_reward, reward_info = theirs._get_rew(x_velocity, action)
        healthy = getattr(theirs, "is_healthy", True)
        unhealthy += not healthy
        assert np.array_equal(obs[0], expected_obs)
        assert reward[0] == pytest.approx(expected_reward, rel=1e-6, abs=1e-9)
        assert bool(terminated[0]) == (not healthy)
        expected_info = {"x_position": qpos[0], "x_velocity": x_velocity, **reward_info}
        if name != "HalfCheetah":
            expected_info["z_distance_from_origin"] = qpos[1] - theirs.init_qpos[1]
        assert info.keys() == expected_info.keys()
        for key, value in expected_info.items():
            assert info[key][0] == pytest.approx(float(value), rel=1e-6, abs=1e-9), key
    assert unhealthy >= (0 if name == "HalfCheetah" else 10)


# the legs' start in the air: the hopper's and walker's hinges rest at their ranges' upper ends
# (0) in the model's pose, where MuJoCo's soft limits and tumble's rigid ones part at once (a
# modelling difference no step size removes: measured 0.015 rad in the first 0.02 s); bent
# halfway they stay clear of the limits for the run
LEGS = {"HalfCheetah": None, "Hopper": [-0.6, -0.6, 0.0], "Walker2d": [-0.6, -0.6, 0.0, -0.4, -0.8, 0.2]}


@pytest.mark.parametrize("name, make", RUNNERS)
def test_runners_in_the_air_converge_to_mujoco_rk4_at_first_order(name, make):
    """The model's dynamics without contact: the runner lifted 1 m (its root's z), its legs bent
    (``LEGS``), moving at random rates, given 0.1 s of random controls (controls within +-0.3: it
    falls 5 cm, its legs swing short of their ranges on their motors, springs, dampers and armature) against MuJoCo's RK4 at a step of 1e-4 s
    (converged: its change from 1e-3 s is under 1e-6). tumble's step is first order
    (docs/joints.md): each halving of the step halves the largest difference of qpos (ratios
    1.7-2.3 admit first order only). Were a mass, inertia (settotalmass), gear, armature, spring or
    damper read differently, the difference would stop shrinking. Measured at 0.004 to 0.0005 s:
    cheetah 2.4e-3 to 3.1e-4 (ratios 1.95-1.99; 1.85-1.91 against the Euler its file asks for,
    taken for RK4 until session 31), hopper 8.6e-4 to 1.1e-4 (2.00), walker 4.9e-3 to
    6.0e-4 (2.00-2.01)."""
    env_dt = 0.02
    env = make()
    actions = np.random.default_rng(6).uniform(-0.3, 0.3, size=(5, len(env.actuators)))

    def run(env, h):
        env.reset(seed=1)
        qpos = env.init_qpos.copy()
        qpos[1] += 1.0
        if LEGS[name] is not None:
            qpos[3:] = LEGS[name]
        env.set_state(qpos, np.random.default_rng(2).normal(0, 0.5, len(env.init_qvel)))
        out = []
        for a in actions:
            env.step(a.astype(np.float32))
            out.append(env.data.qpos.copy() if hasattr(env, "data") else env._copies.state()[0][0].copy())
        return np.array(out)

    reference = run(mujoco_runner(name, 1e-4, int(round(env_dt / 1e-4))), 1e-4)
    # no leg reaches its range (MuJoCo's limits are soft, tumble's rigid: not what this compares)
    for k, c in enumerate(env.robot.kinematics.coordinates):
        joint = env.robot.joints[c.name]
        if joint.lower is not None:
            assert np.all((reference[:, k] > joint.lower + 0.05) & (reference[:, k] < joint.upper - 0.05)), c.name
    errors = []
    for h in (0.004, 0.002, 0.001, 0.0005):
        errors.append(np.abs(run(make(timestep=h, frame_skip=int(round(env_dt / h))), h) - reference).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)


def test_a_cheetah_at_rest_stands_on_contacts_that_carry_its_weight():
    """Statics: the cheetah (14 kg by ``settotalmass``) left with zero controls comes to rest on its
    feet (every rate under 1e-5 after 10 s: measured 4e-7), and the vertical contact forces of
    the last step carry the weight of every moving body but one: the virtual link between the
    root's two slides (``mjcf.LIGHT_VIRTUAL_FRACTION`` of the torso, 6.25 mg: no row but the tree's
    acts on the root's joints) hangs on the world's x slide, which holds its weight. To 1e-6
    relative (at rest the step's impulses balance gravity to the rates' change); and to 1e-5 of
    MuJoCo's m g (137.34 N: measured 137.340092, the virtual links' 9e-7 of the mass; 137.40 when
    they weighed 1e-3 of their bodies, before session 31). Only its feet touch: its legs do not
    touch each other (MuJoCo's contype/conaffinity)."""
    env = te.HalfCheetah()
    env.reset(seed=0)
    for _ in range(200):
        obs, *_ = env.step(np.zeros(6, dtype=np.float32))
    assert np.abs(obs[8:]).max() < 1e-5
    w = env.world
    held = w.mass[w.moving].sum() - w.mass[env.robot.links["torso/rootx"].index]
    contacts = env.sim.contacts()
    assert contacts.force[:, 2].sum() == pytest.approx(held * 9.81, rel=1e-6)
    assert contacts.force[:, 2].sum() == pytest.approx(14.0 * 9.81, rel=1e-5)
    touching = set(contacts.names_a.tolist()) | set(contacts.names_b.tolist())
    assert touching == {"cheetah/world/floor", "cheetah/bfoot", "cheetah/ffoot"}


@pytest.mark.parametrize("make, key", [
    (lambda: te.Hopper(healthy_z_range=(1.0, 0.5)), "healthy_z_range"),
    (lambda: te.Walker2d(healthy_angle_range="wide"), "healthy_angle_range"),
    (lambda: te.HalfCheetah(ctrl_cost_weight=float("nan")), "ctrl_cost_weight"),
    (lambda: te.HalfCheetah(forward_reward_weight=True), "forward_reward_weight"),
    (lambda: te.Hopper(frame_skip=0), "frame_skip"),
    (lambda: te.Ant(contact_force_range=(1.0, -1.0)), "contact_force_range"),
    (lambda: te.Ant(contact_cost_weight="small"), "contact_cost_weight"),
    (lambda: te.Humanoid(contact_cost_range=(10.0, 1.0)), "contact_cost_range"),
    (lambda: te.Humanoid(contact_cost_weight=None), "contact_cost_weight"),
    (lambda: te.Humanoid(healthy_z_range="tall"), "healthy_z_range"),
    (lambda: te.HumanoidStandup(uph_cost_weight=float("inf")), "uph_cost_weight"),
    (lambda: te.HumanoidStandup(impact_cost_range=(0.0,)), "impact_cost_range"),
    (lambda: te.HumanoidStandup(impact_cost_weight=True), "impact_cost_weight"),
])
def test_bad_runner_settings_are_one_line(make, key):
    """Bad task settings: ``tb.InputError`` with one line naming the key."""
    with pytest.raises(tb.InputError) as err:
        make()
    assert f"{key}: " in str(err.value) and "\n" not in str(err.value)


def test_runners_pass_gymnasiums_env_checker_and_register():
    """Gymnasium's own checks of the API pass, and ``gymnasium.make("tumble/NAME-v5")`` makes each
    with Gymnasium's episode limit (1000 steps)."""
    from gymnasium.utils.env_checker import check_env

    for name, make in CHECKED:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            check_env(make())
        env = gym.make(f"tumble/{name}-v5")
        assert isinstance(env.unwrapped, make) and env.spec.max_episode_steps == 1000


@pytest.mark.parametrize("name, make", EVERY)
def test_vector_runner_copies_equal_single_envs_bit_for_bit(name, make):
    """``ModelVectorEnv``'s copy i of a runner is the single environment seeded seed + i, bit for bit,
    through terminations (the hopper and walker fall under random controls), truncations (30 steps)
    and autoresets: 4 copies stacked in one spot of one world, each in an env of its own over one
    floor (tests/test_envs.py), touching only the floor and themselves. A reset copy's contacts
    start without the warm start of its last episode, in the vector env as in the single one
    (``Robot._restart_warm_starts``: resetting the copy that owns the shared floor once dropped the
    floor contacts of every copy, and copy 1 parted from its single env at step 16)."""
    from tests import test_envs

    venv = gym.make_vec(f"tumble/{name}-v5", num_envs=4, vectorization_mode="vector_entry_point",
                        max_episode_steps=30)
    nu = venv.single_action_space.shape[0]
    episodes = test_envs._compare_vector_with_singles(venv, make, 4, 70, 30, 3, nu, np.random.default_rng(0))
    assert episodes >= 8


def test_an_episode_with_contacts_is_the_same_whatever_came_before():
    """Reproducible episodes with contacts: a cheetah put on its feet (``set_state`` at a rest pose,
    touching the floor) and given the same actions repeats its episode bit for bit whether it
    stood there before or not. The contacts it had before the reset are dropped
    (``ContactSolver.forget``): kept, they warm-started the new episode's first step with their
    old impulses (which match the same feet on the same floor), and the episode parted by 3.7
    (measured, with ``forget`` a no-op)."""
    env = te.HalfCheetah()
    env.reset(seed=0)
    for _ in range(100):
        env.step(np.zeros(6, dtype=np.float32))
    rest = env._copies.state()[0][0].copy()
    actions = np.random.default_rng(5).uniform(-1, 1, size=(20, 6)).astype(np.float32)

    def episode(env):
        env.reset(seed=11)
        env.set_state(rest, np.zeros(9))
        return np.array([env.step(a)[0] for a in actions])

    fresh = episode(te.HalfCheetah())
    assert env.sim.contacts().body_a.size == 2  # it stood on both feet, at that pose
    assert np.array_equal(episode(env), fresh)


# ---------------------------------------------------------------------------------------- the ant


def test_ant_starts_where_gymnasiums_starts():
    """Same seed, same start (qpos uniform +-0.1, quaternion included, as drawn; qvel 0.1 N(0, 1)),
    the same reset info, and no contact forces in the observation yet (MuJoCo's reset zeroes
    ``cfrc_ext``; tumble's copy has had no step), even after an episode that ended on its feet."""
    ours, theirs = te.Ant(), mujoco_runner("Ant")
    for seed in (0, 5):
        o1, i1 = ours.reset(seed=seed)
        o2, i2 = theirs.reset(seed=seed)
        assert o1.shape == o2.shape == (105,) and np.array_equal(o1, o2)
        assert i1.keys() == i2.keys() and all(i1[k] == i2[k] for k in i1)
        for _ in range(30):
            ours.step(np.zeros(8, dtype=np.float32))
        assert np.abs(ours._copies.external_forces()).max() > 0.5  # standing: its feet carry it


class _Forces:
    """A task's ``links`` stand-in giving chosen external forces (the arithmetic test below)."""

    def __init__(self, forces):
        self.forces = forces

    def external_forces(self):
        return self.forces[None]


def test_ant_reward_termination_and_info_are_gymnasiums():
    """The ant's arithmetic against Gymnasium's own on the same states and the same external forces
    (random states, some fallen (z < 0.2) or thrown (z > 1), random forces of up to 3 N and N m,
    many past the +-1 clip): Gymnasium's environment set to the state and its ``cfrc_ext`` set to
    the forces, asked its observation, reward and health. Equal to 1e-6 relative (the control cost
    squared in float32 there, float64 here)."""
    ours, theirs = te.Ant(), mujoco_runner("Ant")
    ours.reset(seed=0)
    theirs.reset(seed=0)
    rng = np.random.default_rng(9)
    unhealthy = 0
    for k in range(30):
        before = ours.init_qpos + rng.normal(0, 0.2, 15)
        qpos = before + rng.normal(0, 0.05, 15)
        qpos[2] = rng.choice([0.1, 0.5, 0.6, 1.2]) if k % 3 == 0 else qpos[2]
        qvel = rng.normal(0, 2, 14)
        forces = rng.uniform(-3, 3, (13, 6))
        action = rng.uniform(-1, 1, 8).astype(np.float32)
        ours.remember(before[None], qvel[None])
        obs = ours.observe(qpos[None], qvel[None], _Forces(forces))
        reward, terminated, info = ours.evaluate(obs, action[None].astype(np.float64))
        theirs.set_state(qpos, qvel)
        theirs.data.cfrc_ext[1:] = forces
        velocity = (qpos[:2] - before[:2]) / theirs.dt
        expected_reward, reward_info = theirs._get_rew(velocity[0], action)
        unhealthy += not theirs.is_healthy
        np.testing.assert_allclose(obs[0], theirs._get_obs(), rtol=0, atol=0)
        assert reward[0] == pytest.approx(expected_reward, rel=1e-6)
        assert bool(terminated[0]) == (not theirs.is_healthy)
        expected = {"x_position": qpos[0], "y_position": qpos[1], "distance_from_origin": np.linalg.norm(qpos[:2]),
                    "x_velocity": velocity[0], "y_velocity": velocity[1], **reward_info}
        assert info.keys() == expected.keys()
        for key, value in expected.items():
            assert info[key][0] == pytest.approx(float(value), rel=1e-6, abs=1e-12), key
    assert unhealthy >= 5


def test_ant_in_the_air_converges_to_mujoco_rk4_at_first_order():
    """The ant's dynamics without contact (a free root, MuJoCo's quaternion and body-frame angular
    velocity in its qpos and qvel): lifted to z = 2 m, tilted, spinning, its ankles set inside
    their ranges (the model's pose has them at 0, outside: MuJoCo's soft limits and tumble's rigid
    ones part there), 0.1 s of random controls within +-0.3 against MuJoCo's RK4 at 1e-4 s; each
    halving of tumble's step halves the largest qpos difference (first order: ratios 1.7-2.3)."""
    env_dt = 0.02
    env = te.Ant()
    actions = np.random.default_rng(6).uniform(-0.3, 0.3, size=(5, 8))
    start = env.init_qpos.copy()
    start[2] = 2.0
    start[3:7] = [0.99, 0.05, -0.1, 0.02]
    start[3:7] /= np.linalg.norm(start[3:7])
    start[7:] = np.radians([10, 50, -10, -50, 5, -50, -5, 50])
    rate = np.random.default_rng(2).normal(0, 0.5, 14)

    def run(env):
        env.reset(seed=1)
        env.set_state(start, rate)
        out = []
        for a in actions:
            env.step(a.astype(np.float32))
            out.append(env.data.qpos.copy() if hasattr(env, "data") else env._copies.state()[0][0].copy())
        return np.array(out)

    reference = run(mujoco_runner("Ant", 1e-4, int(round(env_dt / 1e-4))))
    assert_first_order(reference, env.robot.kinematics.coordinates, 0.05, run, te.Ant, env_dt,
                       (0.004, 0.002, 0.001, 0.0005))


def assert_first_order(reference, coordinates, clearance, run, make, env_dt, steps):
    """The in-air comparisons' common end: no coordinate of ``reference`` (MuJoCo's qpos per
    environment step) comes within ``clearance`` (rad or m) of its range (MuJoCo's soft limits
    and tumble's rigid ones would part there), and ``run(make(timestep=h, ...))`` for each ``h``
    of ``steps`` (each half the last) is a first-order approach to it: each halving halves the
    largest qpos difference (ratios 1.7-2.3)."""
    for c in coordinates:
        if c.lower is not None:
            q = reference[:, c.qpos]
            assert np.all((q > c.lower + clearance) & (q < c.upper - clearance)), c.name
    errors = [np.abs(run(make(timestep=h, frame_skip=int(round(env_dt / h)))) - reference).max() for h in steps]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)


def test_an_ants_external_forces_obey_newtons_law_and_carry_its_weight():
    """``cfrc_ext`` by Newton's second law: over each simulator step the ant's linear momentum
    (sum of m v over its bodies; the joints' impulses, armature's included, are internal and
    cancel) changes by dt (sum of its bodies' external forces - m g), to 1e-9 of m g dt (the
    forces are the step's contact impulses over dt: an identity up to rounding). Left with zero
    controls it stands: over a second after 10 s the mean vertical force is its weight to 1e-3
    (its hips keep a 0.017 rad/s oscillation, docs/robots.md; the bound on the rates, 0.05 rad/s,
    guards that gap from growing). MuJoCo's ant, the same mean of its ``cfrc_ext`` (its total
    weight, 8.94 N: tumble's masses are MuJoCo's; it too still moves at 10 s, 0.04 rad/s)."""
    env = te.Ant(reset_noise_scale=0.0)
    env.reset(seed=0)
    w = env.world
    moving = np.flatnonzero(w.moving)
    weight = w.mass[moving].sum() * 9.81
    dt = env.sim.dt
    def step_and_check():
        """One simulator step; its momentum change against its external forces; their vertical sum."""
        before = (w.mass[moving, None] * w.v[moving]).sum(axis=0)
        env.sim.step(1)
        after = (w.mass[moving, None] * w.v[moving]).sum(axis=0)
        forces = env._copies.external_forces()[0]  # unclipped (13, 6): torque, force
        total = forces[:, 3:].sum(axis=0) - (0.0, 0.0, weight)
        np.testing.assert_allclose((after - before) / dt, total, rtol=0, atol=1e-9 * weight)
        return forces[:, 5].sum()

    for k in range(200):
        obs, *_ = env.step(np.zeros(8, dtype=np.float32))
        if k % 25 == 24:  # landing, settling
            step_and_check()
    assert np.abs(obs[13:27]).max() < 0.05
    vertical = [step_and_check() for _ in range(int(round(1.0 / dt)))]  # its last second, every step
    assert np.mean(vertical) == pytest.approx(weight, rel=1e-3)
    theirs = mujoco_runner("Ant")
    theirs.reset(seed=0)
    theirs.set_state(theirs.init_qpos, theirs.init_qvel)
    for _ in range(200):
        theirs.step(np.zeros(8))
    import mujoco

    m, d = theirs.model, theirs.data
    assert m.body_mass.sum() * 9.81 == pytest.approx(weight, rel=1e-12)
    theirs_vertical = []
    for _ in range(int(round(1.0 / m.opt.timestep))):  # its last second, every step (still moving: 0.04 rad/s)
        mujoco.mj_step(m, d)
        mujoco.mj_rnePostConstraint(m, d)
        theirs_vertical.append(d.cfrc_ext[1:, 5].sum())
    assert np.mean(theirs_vertical) == pytest.approx(weight, rel=1e-3)
