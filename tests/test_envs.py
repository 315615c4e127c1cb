"""tumble.envs: MJCF models as Gymnasium environments and vector environments.

Compared with: Gymnasium's own ``InvertedPendulum-v5`` stepped by MuJoCo on the same model file
(its start, its motion at a converged step, and a controller's episode), Gymnasium's env checker,
and single environments (a vector environment's copies must be them, bit for bit)."""

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import tumble as tb  # noqa: E402
import tumble.envs as te  # noqa: E402

# a pendulum held by a position servo (kp, kv: MuJoCo's spring and damper in the actuator): the
# model takes the copy-by-copy path of tumble.envs._Copies (set_controls, Kinematics.qpos/qvel)
SERVO = """<mujoco model="servo"><option timestep="0.005"/><worldbody>
  <body name="arm" pos="0 0 2"><joint name="hinge" type="hinge" axis="0 1 0" damping="0.1"/>
  <geom name="bob" type="sphere" size="0.05" pos="0 0 -0.5" mass="1" contype="0"/></body></worldbody>
  <actuator><position name="servo" joint="hinge" kp="20" kv="1" ctrlrange="-1 1"/></actuator></mujoco>"""


class ServoPendulum(te.ModelEnv):
    """A task on SERVO (written next to the test): reward -angle^2, never terminated."""

    path = None

    def __init__(self, **kwargs):
        super().__init__(self.path, frame_skip=4, reset_noise_scale=0.1, **kwargs)

    def evaluate(self, observation, action):
        return -observation[:, 0] ** 2, np.zeros(len(observation), dtype=bool), {}


@pytest.fixture(scope="module")
def servo_model(tmp_path_factory):
    path = tmp_path_factory.mktemp("envs") / "servo.xml"
    path.write_text(SERVO)
    ServoPendulum.path = str(path)
    return ServoPendulum


def mujoco_gym(env_id, timestep=None):
    """Gymnasium's own ``env_id`` stepped by MuJoCo (the unwrapped environment); with ``timestep``,
    a reference: the same environment dt in finer steps of MuJoCo's RK4 (some files, the
    pusher's, leave MuJoCo's semi-implicit Euler on, whose first-order error at 2e-4 s, 1.9e-4,
    was as large as tumble's at 0.001 s)."""
    mujoco = pytest.importorskip("mujoco")
    env = gym.make(env_id).unwrapped
    if timestep is not None:
        env_dt = env.dt
        env.model.opt.timestep = timestep
        env.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        env.frame_skip = int(round(env_dt / timestep))
    return env


def mujoco_env(timestep=None):
    return mujoco_gym("InvertedPendulum-v5", timestep)


def first_order_errors(run, reference, make, env_dt, steps):
    """The largest differences from ``reference`` of ``run`` on ``make(timestep=h, frame_skip=)``
    (the same environment dt ``env_dt``) for each step h of ``steps``, each half the last: they
    must halve with it (ratios 1.7-2.3 admit first order only). Returns them."""
    errors = [np.abs(run(make(timestep=h, frame_skip=int(round(env_dt / h)))) - reference).max() for h in steps]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)
    return errors


def open_loop(seed, actions):
    """An environment's open-loop episode: ``run(env)`` resets it with ``seed`` and steps it through
    ``actions``; (len(actions) + 1, d) the observations, the start's first."""
    def run(env):
        return np.array([env.reset(seed=seed)[0]] + [env.step(a)[0] for a in actions])

    return run


def test_reset_starts_where_gymnasiums_mujoco_env_starts():
    """Same seed, same start: the noise is drawn as Gymnasium's MuJoCo environments draw it (qpos,
    then qvel, uniform in +-0.01 from the env's generator), and the observation is (qpos, qvel)
    as set. Exact: the same numbers pass through no arithmetic."""
    ours, theirs = te.InvertedPendulum(), mujoco_env()
    for seed in (0, 3, 12345):
        o1, _ = ours.reset(seed=seed)
        o2, _ = theirs.reset(seed=seed)
        assert np.array_equal(o1, o2)
        assert 0 < np.abs(o1).max() <= 0.01


def test_episode_converges_to_mujoco_rk4_at_first_order():
    """Open loop (control 0.5 for 8 steps of 0.04 s, the pole falling to 0.5 rad) from the same
    start: tumble at timesteps 0.02 (the file's) to 0.0025 s against MuJoCo's RK4 at 0.0005 s,
    which is converged (its own change from 0.005 s is 1.6e-8). tumble's step is first order
    (docs/joints.md): each halving of the step halves the largest difference (measured ratios
    1.92-1.99; the bounds 1.7-2.3 admit first order only), and at 0.0025 s it is 2.4e-3. Were
    the two engines' models different (mass, inertia, gear, damping, the pole's 1 mm lean), the
    difference would stop shrinking."""
    run = open_loop(3, [np.array([0.5], dtype=np.float32)] * 8)
    reference = run(mujoco_env(0.0005))
    assert abs(reference[-1, 1]) > 0.4  # the pole fell well past the task's 0.2 rad
    errors = first_order_errors(run, reference, te.InvertedPendulum, 0.04, (0.02, 0.01, 0.005, 0.0025))
    assert errors[-1] < 3e-3


def test_lqr_from_the_linearized_step_balances_on_tumble_and_on_mujoco():
    """A controller designed on tumble's linearized step (``transition_jacobians``: A, B of one
    0.02 s step about upright, composed into the env's 0.04 s step, then discrete LQR) earns the
    whole episode (1000 of 1000; Gymnasium's threshold is 950) on tumble's environment and on
    Gymnasium's MuJoCo one (sim-to-sim transfer), from three seeds. Both come to rest at the same
    state to 1e-6: the cart 11.75 mm aside, the pole leaning 1.67 mrad, set by the model's pole,
    whose top is 1 mm off its axis (``fromto="0 0 0 0.001 0 0.6"``)."""
    scipy_linalg = pytest.importorskip("scipy.linalg")
    env = te.InvertedPendulum()
    env.reset(seed=0)
    env.set_state(np.zeros(2), np.zeros(2))
    lin = env.robot.kinematics.transition_jacobians(env.sim, inputs="controls")
    A2, B2 = lin.A @ lin.A, (lin.A + np.eye(4)) @ lin.B
    Q, R = np.diag([1.0, 10.0, 0.1, 0.1]), np.array([[0.1]])
    P = scipy_linalg.solve_discrete_are(A2, B2, Q, R)
    K = np.linalg.solve(R + B2.T @ P @ B2, B2.T @ P @ A2)
    ends = {}
    for name in ("tumble/InvertedPendulum-v5", "InvertedPendulum-v5"):
        if name == "InvertedPendulum-v5":
            pytest.importorskip("mujoco")
        for seed in range(3):
            e = gym.make(name)
            o, _ = e.reset(seed=seed)
            total, done = 0.0, False
            while not done:
                o, r, terminated, truncated, _ = e.step(np.clip(-K @ o, -3, 3).astype(np.float32))
                total += r
                done = terminated or truncated
            assert total == 1000 and not terminated
            ends[name, seed] = o
    for seed in range(3):
        assert np.abs(ends["tumble/InvertedPendulum-v5", seed] - ends["InvertedPendulum-v5", seed]).max() < 1e-6
    assert abs(ends["InvertedPendulum-v5", 0][0] - 0.01175) < 1e-4


def test_reacher_starts_as_gymnasiums_and_converges_to_mujoco_rk4_at_first_order():
    """Gymnasium's ``Reacher-v5`` on its own file (two hinges with armature 1 and damping 1, motors of
    gear 200, a target on two slides with ``ref``): the same seed gives the same start (the angles,
    the target's goal drawn by rejection, the rates: the observation's fingertip-less-target part
    read from the bodies, to 1e-16), and 10 steps of random controls converge to MuJoCo's RK4 at
    0.0002 s (converged: its own change from 0.002 s is 3e-8) at first order: measured 9.1e-3,
    4.5e-3, 2.3e-3, 1.1e-3 at timesteps 0.01 (the file's) to 0.00125 s, each halving halving it.
    Were the target's ``ref`` not read, its qpos would be off by 0.1 at the start."""
    actions = np.random.default_rng(3).uniform(-1, 1, size=(10, 2)).astype(np.float32)

    run = open_loop(2, actions)

    def mujoco_reacher(timestep):
        return mujoco_gym("Reacher-v5", timestep)

    for seed in (0, 7):
        o1, _ = te.Reacher().reset(seed=seed)
        o2, _ = mujoco_reacher(0.01).reset(seed=seed)
        assert np.abs(o1 - o2).max() < 1e-15
    reference = run(mujoco_reacher(0.0002))
    errors = first_order_errors(run, reference, te.Reacher, 0.02, (0.01, 0.005, 0.0025, 0.00125))
    assert errors[0] < 0.02


def test_same_seed_and_actions_give_the_same_episode_whatever_came_before():
    """Reproducible episodes: an environment reset with a seed and given the same actions repeats
    the episode bit for bit, fresh or after other episodes (the reset clears the joints' warm start
    and readings: ``Kinematics.set_state``)."""
    actions = np.random.default_rng(5).uniform(-3, 3, size=(30, 1)).astype(np.float32)

    def episode(env):
        out = [env.reset(seed=11)[0]]
        for a in actions:
            o, r, terminated, _, _ = env.step(a)
            out.append(np.append(o, [r, terminated]))
            if terminated:
                break
        return out

    fresh = te.InvertedPendulum()
    used = te.InvertedPendulum()
    used.reset(seed=99)
    for a in actions[::-1][:12]:
        used.step(a)
    first, second = episode(fresh), episode(used)
    assert len(first) == len(second) > 3
    assert all(np.array_equal(a, b) for a, b in zip(first, second))
    again = episode(fresh)
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def _compare_vector_with_singles(venv, make_single, n, steps, max_steps, seed, nu, rng):
    """Step ``venv`` and ``n`` single environments (``make_single()``, each in a TimeLimit of
    ``max_steps``, reset by hand on the step after their episode ended: Gymnasium's NEXT_STEP
    autoreset) with the same random actions; return how many copies' episodes ended."""
    singles = [gym.wrappers.TimeLimit(make_single(), max_steps) for _ in range(n)]
    v_obs, _ = venv.reset(seed=seed)
    s_obs = np.array([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    assert np.array_equal(v_obs, s_obs)
    low, high = venv.single_action_space.low, venv.single_action_space.high
    ended, episodes = [False] * n, 0
    for _ in range(steps):
        actions = rng.uniform(low, high, size=(n, nu))
        v_obs, v_rew, v_term, v_trunc, _ = venv.step(actions)
        for i, e in enumerate(singles):
            if ended[i]:
                o, r, term, trunc = e.reset()[0], 0.0, False, False
            else:
                o, r, term, trunc, _ = e.step(actions[i])
            ended[i] = term or trunc
            episodes += ended[i]
            assert np.array_equal(v_obs[i], o)
            assert (v_rew[i], v_term[i], v_trunc[i]) == (r, term, trunc)
    return episodes


def test_vector_env_copies_equal_single_envs_bit_for_bit():
    """``ModelVectorEnv``'s copy i is the single environment seeded seed + i, bit for bit, through
    terminations, truncations (a limit of 25 steps) and the autoresets after them: the copies share
    one world and one step, and nothing of one reaches another. Random actions make the poles
    fall, so episodes end often (counted). Made through ``gymnasium.make_vec`` too."""
    rng = np.random.default_rng(1)
    venv = gym.make_vec("tumble/InvertedPendulum-v5", num_envs=4, vectorization_mode="vector_entry_point",
                        max_episode_steps=25)
    assert isinstance(venv.unwrapped, te.ModelVectorEnv)
    assert venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    episodes = _compare_vector_with_singles(venv, te.InvertedPendulum, 4, 60, 25, 7, 1, rng)
    assert episodes >= 8
    assert venv.observation_space.shape == (4, 4) and venv.action_space.shape == (4, 1)


def test_vector_reacher_copies_equal_single_envs_bit_for_bit():
    """The same for ``Reacher`` (the tree solve, two motors, the task's own reset and the fingertip
    read from each copy's bodies): 5 copies for 60 steps, each episode truncated at 50."""
    venv = gym.make_vec("tumble/Reacher-v5", num_envs=5, vectorization_mode="vector_entry_point")
    assert venv.unwrapped.sim.joint_settings.method == "tree"
    episodes = _compare_vector_with_singles(venv, te.Reacher, 5, 60, 50, 3, 2, np.random.default_rng(8))
    assert episodes == 5


def test_vector_env_of_a_servo_model_takes_the_copy_by_copy_path_with_the_same_bits(servo_model):
    """A model whose actuator is a position servo (a spring and damper in the actuator) does not
    take the array path (``_Copies._fast`` is None): its controls go through ``Robot.set_controls``
    and its observations through ``Kinematics.qpos``/``qvel``, copy by copy; the copies are still
    the single environments, bit for bit (3 copies, truncated every 10 steps)."""
    venv = te.ModelVectorEnv(servo_model, 3, max_episode_steps=10)
    assert venv._copies._fast is None
    episodes = _compare_vector_with_singles(venv, servo_model, 3, 35, 10, 21, 1, np.random.default_rng(2))
    assert episodes == 9
    # the servo holds the arm where its spring kp (0.5 - q) balances gravity's m g l sin q (1 kg
    # on 0.5 m): the root by brentq; the environment does not sleep (a sleeping world froze the
    # arm 1.3 mrad short of it, creeping slower than the sleep threshold: measured)
    from scipy.optimize import brentq

    env = servo_model()
    env.reset(seed=0)
    for _ in range(1000):
        o, *_ = env.step(np.array([0.5], dtype=np.float32))
    rest = brentq(lambda q: 20.0 * (0.5 - q) - 9.81 * 0.5 * np.sin(q), 0.0, 0.5)
    assert abs(o[0] - rest) < 1e-6 and abs(o[1]) < 1e-6


def test_gymnasium_env_checker_passes():
    """Gymnasium's own checks of the API (spaces, seeding determinism, reset and step returns,
    render) pass on tumble's environment."""
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # its advice on unbounded and unnormalised boxes
        check_env(te.InvertedPendulum(render_mode="rgb_array"))
        check_env(te.Reacher())
        check_env(te.InvertedDoublePendulum())
        check_env(te.Pusher())
        check_env(te.Swimmer())


def test_render_draws_the_pendulum():
    """``render_mode="rgb_array"``: a (240, 320, 3) uint8 image from the default camera (side view,
    ``tb.Camera``), in which the pole and cart are drawn (pixels of a body: the segmentation)."""
    env = te.InvertedPendulum(render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    seen = env.camera.capture(env.world).body
    assert {int(env.robot.links["pole"].index), int(env.robot.links["cart"].index)} <= set(np.unique(seen).tolist())
    assert te.InvertedPendulum().render() is None


def test_copies_of_a_model_that_touches_get_envs_of_their_own_over_one_floor():
    """Copies share one world: a model whose geoms touch (Gymnasium's hopper: its foot and the
    floor, its links each other) gets each copy's bodies in an env of their own (``CollisionFilter.
    env`` k + 1: copies pass through each other) over the first copy's floor (env 0, the others
    load without theirs: ``load_mjcf(world_geoms=False)``), so each touches the floor and itself
    as alone (bit for bit: tests/test_envs_runners.py). A single environment takes it as it is."""
    hopper = te.gymnasium_asset("hopper.xml")
    venv = te.ModelVectorEnv(te.ModelEnv, 3, model=hopper)
    w = venv.world
    floors = [i for i in range(w.body_count) if w.names[i].endswith("world/floor")]
    assert [w.names[i] for i in floors] == ["env0/world/floor"] and w.collision_filters[floors[0]].env == 0
    for k, robot in enumerate(venv._copies.robots):
        assert {w.collision_filters[link.index].env for key, link in robot.links.items()
                if not key.startswith("world") and w.shapes[link.index] is not None} == {k + 1}
    a, b = venv._copies.robots[1].links["foot"], venv._copies.robots[2].links["foot"]
    assert not w.should_collide(a, b) and w.should_collide(a, floors[0])
    env = te.ModelEnv(hopper, frame_skip=4)
    o, _ = env.reset(seed=0)
    assert o.shape == (env.robot.kinematics.nq + env.robot.kinematics.nv,)
    assert env.action_space.shape == (3,)
    env.step(np.zeros(3, dtype=np.float32))


@pytest.mark.parametrize("make, key", [
    (lambda: te.InvertedPendulum(frame_skip=0), "frame_skip"),
    (lambda: te.InvertedPendulum(timestep=-0.01), "timestep"),
    (lambda: te.InvertedPendulum(reset_noise_scale=float("nan")), "reset_noise_scale"),
    (lambda: te.InvertedPendulum(render_mode="human"), "render_mode"),
    (lambda: te.ModelVectorEnv(te.InvertedPendulum, 0), "num_envs"),
    (lambda: te.ModelVectorEnv(object, 2), "env"),
    (lambda: te.ModelVectorEnv(te.InvertedPendulum, 2, max_episode_steps=0), "max_episode_steps"),
    (lambda: te.InvertedPendulum().step(np.zeros(2)), "action"),
    (lambda: te.InvertedPendulum().step(np.array([np.nan])), "action"),
    (lambda: te.ModelVectorEnv(te.InvertedPendulum, 2).step(np.zeros((3, 1))), "action"),
    (lambda: te.ModelVectorEnv(te.InvertedPendulum, 2).reset(seed=[1, 2, 3]), "seed"),
    (lambda: te.ModelVectorEnv(te.InvertedPendulum, 2).reset(seed="x"), "seed"),
    (lambda: te.InvertedDoublePendulum(healthy_reward=None), "healthy_reward"),
])
def test_bad_input_is_one_line(make, key):
    """Bad arguments and actions: ``tb.InputError`` with one line naming the key."""
    with pytest.raises(tb.InputError) as err:
        make()
    assert f"{key}: " in str(err.value) and "\n" not in str(err.value)


@pytest.mark.slow
def test_the_cem_example_learns_to_balance_and_the_policy_balances_on_mujoco_too(tmp_path):
    """examples/control/cem_pendulum.py: the cross-entropy method over linear policies, 48
    candidates a generation run as the copies of one vector environment, reaches a mean return of
    950 of 1000 within 12 generations (measured: 8, about 8 s), from returns of about 25 for the
    first random policies; the policy found earns the whole episode on tumble and on Gymnasium's
    MuJoCo environment (mujoco installed: the test extra)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "control" / "cem_pendulum.py"
    spec = importlib.util.spec_from_file_location("cem_pendulum", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    summary = example.main(["--out", str(tmp_path / "cem")])
    history = summary["history"]
    assert history[0][0] < 100 and history[-1][0] >= 950 and len(history) <= 12
    assert summary["tumble_returns"] == [1000.0] * 3
    assert summary["mujoco_returns"] == [1000.0] * 3
    assert (tmp_path / "cem" / "summary.json").is_file()


# ---------------------------------------------------------------------- the double pendulum


def mujoco_double(timestep=None):
    return mujoco_gym("InvertedDoublePendulum-v5", timestep)


def test_double_pendulum_starts_and_scores_as_gymnasiums():
    """Gymnasium's ``InvertedDoublePendulum-v5``: the same seed gives the same start (exact), and on
    the same states (random angles and rates, the cart clear of the rail's ends) the observation
    (sines, cosines, clipped rates, no limit force) equals Gymnasium's to 1e-12 and the reward,
    termination and info (the tip site's height against 1 m) to 1e-12: the tip is read from the
    bodies (``links(link, point)``) where MuJoCo reads ``site_xpos``."""
    ours, theirs = te.InvertedDoublePendulum(), mujoco_double()
    for seed in (0, 4):
        o1, _ = ours.reset(seed=seed)
        o2, _ = theirs.reset(seed=seed)
        assert o1.shape == (9,) and np.array_equal(o1, o2)
    rng = np.random.default_rng(3)
    fallen = 0
    for _ in range(30):
        qpos = np.array([rng.uniform(-0.8, 0.8), rng.uniform(-2, 2), rng.uniform(-2, 2)])
        qvel = rng.normal(0, 6, 3)
        ours.set_state(qpos, qvel)
        theirs.set_state(qpos, qvel)
        obs = ours.observe(qpos[None], qvel[None], ours._copies.view)
        np.testing.assert_allclose(obs[0], theirs._get_obs(), rtol=0, atol=1e-12)
        reward, terminated, info = ours.evaluate(obs, np.zeros((1, 1)))
        x, _, y = theirs.data.site_xpos[0]
        expected, expected_info = theirs._get_rew(x, y, bool(y <= 1))
        fallen += bool(y <= 1)
        assert bool(terminated[0]) == bool(y <= 1)
        assert reward[0] == pytest.approx(expected, abs=1e-12)
        assert info.keys() == expected_info.keys()
        for key, value in expected_info.items():
            assert info[key][0] == pytest.approx(value, abs=1e-12), key
    assert 5 <= fallen <= 25


def test_double_pendulum_converges_to_mujoco_rk4_at_first_order():
    """Open loop (control 0.3 for 5 steps of 0.05 s: the poles fall, the episode ends at the fifth)
    from the same start: tumble at timesteps 0.01 (the file's) to 0.00125 s against MuJoCo's RK4 at
    0.0002 s (converged: its change from 0.001 s is below 1e-7); each halving of tumble's step
    halves the largest difference of the observation (first order: ratios 1.7-2.3). The
    observation's limit force stays 0 on both (the cart never reaches the rail's ends)."""
    run = open_loop(3, [np.array([0.3], dtype=np.float32)] * 5)
    reference = run(mujoco_double(0.0002))
    assert np.all(reference[:, 8] == 0.0)
    first_order_errors(run, reference, te.InvertedDoublePendulum, 0.05, (0.01, 0.005, 0.0025, 0.00125))


def test_double_pendulum_observes_the_rails_limit_force():
    """The observation's last entry is the rail's limit force on the cart (MuJoCo's
    ``qfrc_constraint[0]``): the cart at the rail's end (x = 1 m), the poles hanging at rest, the
    motor pushing it outward with 500 N (control 1, gear 500): the limit holds the cart with
    -500 N (``limit_force``, unclipped), and the observation reads it clipped to -10 as
    Gymnasium's does. To 5e-4 relative: the soft limit lets the cart 0.34 mm into it, which sets
    the hanging poles swinging at some 5 mrad/s, and their pull on the cart moves the force by up
    to 0.06 N (measured over 40 steps). Pushed inward, the cart leaves the end: force 0."""
    env = te.InvertedDoublePendulum()
    env.reset(seed=0)
    env.set_state(np.array([1.0, np.pi, 0.0]), np.zeros(3))
    assert env.observe(*env._copies.state(), env._copies.view)[0, 8] == 0.0  # not stepped yet
    for _ in range(3):
        obs, *_ = env.step(np.array([1.0], dtype=np.float32))
    assert env._copies.limit_force("slider")[0] == pytest.approx(-500.0, rel=5e-4)
    assert obs[8] == -10.0 and 0.0 < obs[0] - 1.0 < 5e-4  # the soft limit: the cart 0.34 mm into it
    obs, *_ = env.step(np.array([-1.0], dtype=np.float32))
    assert obs[8] == 0.0 and obs[0] < 1.0


def test_vector_double_pendulum_copies_equal_single_envs_bit_for_bit():
    """The double pendulum's vector copies are its single environments, bit for bit (the tip and
    the limit force read per copy), through terminations and autoresets: 4 copies, 40 steps."""
    venv = gym.make_vec("tumble/InvertedDoublePendulum-v5", num_envs=4, vectorization_mode="vector_entry_point")
    episodes = _compare_vector_with_singles(venv, te.InvertedDoublePendulum, 4, 40, 1000, 5, 1,
                                            np.random.default_rng(4))
    assert episodes >= 8


# ---------------------------------------------------------------------------------------- the pusher


def test_pusher_starts_and_scores_as_gymnasiums():
    """Gymnasium's ``Pusher-v5``: the same seed gives the same start (the object's place drawn by
    rejection, the rates; exact), and on the same states (random arm angles and rates, object and
    goal places) the observation (the fingertip, object and goal read from the bodies) equals
    Gymnasium's to 1e-12 and the reward and info to 1e-6 (the control cost in float32 there)."""
    ours, theirs = te.Pusher(), mujoco_gym("Pusher-v5")
    for seed in (0, 6):
        o1, _ = ours.reset(seed=seed)
        o2, _ = theirs.reset(seed=seed)
        assert o1.shape == (23,) and np.array_equal(o1, o2)
    rng = np.random.default_rng(2)
    for _ in range(20):
        qpos = ours.init_qpos + np.concatenate([rng.uniform(-0.5, 0.5, 7), rng.uniform(-0.3, 0.3, 4)])
        qvel = rng.normal(0, 1, 11)
        ours.set_state(qpos, qvel)
        theirs.set_state(qpos, qvel)
        obs = ours.observe(qpos[None], qvel[None], ours._copies.view)
        np.testing.assert_allclose(obs[0], theirs._get_obs(), rtol=0, atol=1e-12)
        action = rng.uniform(-2, 2, 7).astype(np.float32)
        reward, terminated, info = ours.evaluate(obs, action[None].astype(np.float64))
        expected, expected_info = theirs._get_rew(action)
        assert not terminated[0] and reward[0] == pytest.approx(expected, rel=1e-6)
        assert info.keys() == expected_info.keys()
        for key, value in expected_info.items():
            assert info[key][0] == pytest.approx(float(value), rel=1e-6), key


def test_pusher_converges_to_mujoco_rk4_at_first_order():
    """The arm's dynamics (seven joints with armature 0.04 and damping, motors; a wrist of three
    joints on turning parents, where the armature must resist the velocity-product accelerations:
    tests/physics/test_mjcf.py's wrist tests): from the middle of its joints' ranges (the model's
    pose has the elbow at its range's end, where MuJoCo's soft limits and tumble's rigid ones part
    at once), 5 steps of small random controls, the arm swinging clear of the object and of its
    ranges, against MuJoCo's RK4 at 1e-3 s (converged: 1.3e-10 from 1e-4 s); each halving of
    tumble's step halves the largest difference of the observation (first order: ratios 1.7-2.3;
    measured 2.00, 2.4e-3 at 0.01 s to 2.9e-4 at 0.00125 s). Before session 31's armature fix the
    difference did not shrink with the step."""
    actions = np.random.default_rng(5).uniform(-0.5, 0.5, size=(5, 7)).astype(np.float32)
    env = te.Pusher()
    start = env.init_qpos.copy()
    start[-4:] = [-0.2, 0.1, 0.0, 0.0]
    for k, c in enumerate(env.robot.kinematics.coordinates[:7]):
        joint = env.robot.joints[c.name]
        if joint.lower is not None and np.isfinite(joint.lower) and np.isfinite(joint.upper):
            start[k] = 0.5 * (joint.lower + joint.upper)

    def run(env):
        env.reset(seed=2)
        env.set_state(start, np.zeros(11))
        return np.array([env.step(a)[0] for a in actions])

    reference = run(mujoco_gym("Pusher-v5", 0.001))
    for k, c in enumerate(env.robot.kinematics.coordinates[:7]):
        joint = env.robot.joints[c.name]
        if joint.lower is not None:
            assert np.all((reference[:, k] > joint.lower + 0.02) & (reference[:, k] < joint.upper - 0.02)), c.name
    first_order_errors(run, reference, te.Pusher, 0.05, (0.01, 0.005, 0.0025, 0.00125))


def test_pusher_registered_with_gymnasiums_limits_and_bad_weights_rejected():
    """``gym.make("tumble/Pusher-v5")`` is the pusher with Gymnasium's 100-step limit, and
    ``make_vec`` its vector environment; a weight that is not a finite number is one line."""
    env = gym.make("tumble/Pusher-v5")
    assert isinstance(env.unwrapped, te.Pusher) and env.spec.max_episode_steps == 100
    venv = gym.make_vec("tumble/Pusher-v5", 2, vectorization_mode="vector_entry_point")
    assert isinstance(venv, te.ModelVectorEnv) and venv.num_envs == 2
    for key in ("reward_near_weight", "reward_dist_weight", "reward_control_weight"):
        with pytest.raises(tb.InputError, match=f"{key}: must be a finite number"):
            te.Pusher(**{key: float("nan")})


def test_vector_pusher_copies_equal_single_envs_bit_for_bit():
    """The pusher's vector copies (each in an env of its own over one table: the arm, the object
    and the table touch) are its single environments, bit for bit, through truncations (10 steps)
    and autoresets: 3 copies, 25 steps of random controls."""
    venv = te.ModelVectorEnv(te.Pusher, 3, max_episode_steps=10)
    episodes = _compare_vector_with_singles(venv, te.Pusher, 3, 25, 10, 8, 7, np.random.default_rng(6))
    assert episodes == 6


# ---------------------------------------------------------------------------------------- the swimmer


def test_swimmer_starts_and_scores_as_gymnasiums():
    """Gymnasium's ``Swimmer-v5``: the same seed gives the same start and reset info (exact), and on
    the same states the observation equals Gymnasium's (exact: the same numbers), the speeds and
    distance to 1e-12 and the reward and its parts to 1e-6 (Gymnasium's control cost is summed in
    float32: 5e-8 apart, measured); never terminated."""
    ours, theirs = te.Swimmer(), mujoco_gym("Swimmer-v5")
    for seed in (0, 5):
        o1, i1 = ours.reset(seed=seed)
        o2, i2 = theirs.reset(seed=seed)
        assert o1.shape == (8,) and np.array_equal(o1, o2)
        assert i1.keys() == i2.keys() and all(i1[k] == i2[k] for k in i2)
    rng = np.random.default_rng(2)
    for _ in range(10):
        before = ours.init_qpos + rng.uniform(-0.5, 0.5, 5)
        qpos, qvel = before + rng.uniform(-0.05, 0.05, 5), rng.normal(0, 1, 5)
        theirs.set_state(qpos, qvel)
        obs = ours.observe(qpos[None], qvel[None])
        assert np.array_equal(obs[0], theirs._get_obs())
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        ours.remember(before[None], qvel[None])
        reward, terminated, info = ours.evaluate(obs, action[None].astype(np.float64))
        velocity = (qpos[:2] - before[:2]) / theirs.dt
        expected, expected_info = theirs._get_rew(velocity[0], action)
        assert not terminated[0] and reward[0] == pytest.approx(expected, rel=1e-6)
        assert info["x_velocity"][0] == pytest.approx(velocity[0], rel=1e-12)
        assert info["y_velocity"][0] == pytest.approx(velocity[1], rel=1e-12)
        assert info["distance_from_origin"][0] == pytest.approx(np.linalg.norm(qpos[:2]), rel=1e-12)
        for key, value in expected_info.items():
            assert info[key][0] == pytest.approx(float(value), rel=1e-6), key


def test_swimmer_converges_to_mujoco_rk4_at_first_order():
    """The swimmer's episode (10 steps of random controls from the same start) against MuJoCo's RK4
    at 1e-3 s (converged: 3e-8 from 5e-4 s): each halving of tumble's step halves the largest
    difference of observation and reward (ratios 1.7-2.3; measured 2.00, 1.9e-2 at the file's
    0.01 s to 4.8e-3 at 0.0025 s): the fluid, the armature and the motors are MuJoCo's. Its root
    (two slides and a hinge on one body) is a chain through two virtual links; weighing 0.1 % of
    the swimmer each (``mjcf.VIRTUAL_FRACTION``), they kept it about 4e-3 from MuJoCo's however fine
    the step (7.3e-3, 4.4e-3, 5.1e-3 at 0.005, 0.0025, 0.00125 s): no row but the tree's acts on
    them, so they weigh ``mjcf.LIGHT_VIRTUAL_FRACTION`` (1e-6) now."""
    from tumble import mjcf

    actions = np.random.default_rng(3).uniform(-1, 1, size=(10, 2)).astype(np.float32)

    def run(env):
        env.reset(seed=2)
        return np.array([np.concatenate([o, [r]]) for o, r, *_ in (env.step(a) for a in actions)])

    env = te.Swimmer()
    virtual = [env.robot.links[name] for name in env.robot.virtual_links]
    assert len(virtual) == 2
    assert all(b.mass == pytest.approx(mjcf.LIGHT_VIRTUAL_FRACTION * env.robot.links["torso"].mass) for b in virtual)
    first_order_errors(run, run(mujoco_gym("Swimmer-v5", 0.001)), te.Swimmer, 0.04, (0.01, 0.005, 0.0025))


def test_vector_swimmer_copies_equal_single_envs_bit_for_bit():
    """The swimmer's vector copies (its geoms touch nothing: no collision stage; each copy's fluid
    record on its own bodies) are its single environments, bit for bit, through truncations (12
    steps) and autoresets: 3 copies, 30 steps of random controls."""
    venv = te.ModelVectorEnv(te.Swimmer, 3, max_episode_steps=12)
    assert sum(isinstance(f, tb.Fluid) for f in venv.world.forces) == 3
    episodes = _compare_vector_with_singles(venv, te.Swimmer, 3, 30, 12, 9, 2, np.random.default_rng(7))
    assert episodes == 6


def test_swimmer_registered_with_gymnasiums_limits_and_bad_weights_rejected():
    env = gym.make("tumble/Swimmer-v5")
    assert isinstance(env.unwrapped, te.Swimmer) and env.spec.max_episode_steps == 1000
    assert env.spec.reward_threshold == 360.0
    venv = gym.make_vec("tumble/Swimmer-v5", 2, vectorization_mode="vector_entry_point")
    assert isinstance(venv, te.ModelVectorEnv) and venv.num_envs == 2
    for key in ("forward_reward_weight", "ctrl_cost_weight"):
        with pytest.raises(tb.InputError, match=f"{key}: must be a finite number"):
            te.Swimmer(**{key: "fast"})
    obs, _ = te.Swimmer(exclude_current_positions_from_observation=False).reset(seed=0)
    assert obs.shape == (10,)
