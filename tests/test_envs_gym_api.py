"""tumble.envs against Gymnasium's API around the task: the frame rate a video plays at
(``metadata["render_fps"]``), the ``"human"`` render mode, pickling an environment mid-episode,
and a vector environment's info on autoreset steps (compared with Gymnasium's own
``SyncVectorEnv`` of the same single environments)."""

import pickle
import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import tumble.envs as te  # noqa: E402
from tumble.errors import InputError  # noqa: E402


def test_metadata_declares_render_fps_as_mujocos_envs_do():
    """``metadata["render_fps"]`` is ``int(round(1 / dt))`` per instance (MujocoEnv's rule and
    values: 25 for the pendulum's 0.04 s, 125 for the hopper's 0.008 s, 20 for a pendulum made with
    ``frame_skip=``2.5x), so ``RecordVideo`` plays the steps in real time and ``check_env`` does not
    warn "No render fps was declared"; the class's own metadata is left alone."""
    from gymnasium.utils.env_checker import check_env

    pendulum, hopper = te.InvertedPendulum(render_mode="rgb_array"), te.Hopper()
    assert pendulum.metadata["render_fps"] == 25 and hopper.metadata["render_fps"] == 125
    assert te.InvertedPendulum(frame_skip=5).metadata["render_fps"] == 10
    assert pendulum.metadata["render_modes"] == ["rgb_array"]
    assert "render_fps" not in te.ModelEnv.metadata
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        check_env(pendulum)
    assert not [w for w in seen if "fps" in str(w.message)]
    # as Gymnasium's MuJoCo environment of the same task declares
    pytest.importorskip("mujoco")
    assert gym.make("InvertedPendulum-v5").unwrapped.metadata["render_fps"] == 25
    assert gym.make("tumble/InvertedPendulum-v5").metadata["render_fps"] == 25


def test_human_render_mode_goes_through_gymnasiums_human_rendering():
    """``gymnasium.make(id, render_mode="human")`` wraps the ``rgb_array`` environment in
    Gymnasium's ``HumanRendering`` (it needs ``render_fps``: a ValueError before); showing a frame
    needs pygame and a display, so without pygame the reset says so (DependencyNotInstalled). The
    environment made directly with ``"human"`` refuses it in one line that names the way."""
    from gymnasium.error import DependencyNotInstalled

    with pytest.warns(UserWarning, match="HumanRendering wrapper is being applied"):
        env = gym.make("tumble/InvertedPendulum-v5", render_mode="human")
    assert isinstance(env, gym.wrappers.HumanRendering)
    assert env.unwrapped.render_mode == "rgb_array" and env.render_mode == "human"
    try:
        import pygame  # noqa: F401
    except ImportError:
        with pytest.raises(DependencyNotInstalled, match="pygame"):
            env.reset(seed=0)
    with pytest.raises(InputError, match="HumanRendering") as caught:
        te.InvertedPendulum(render_mode="human")
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("name", ["Hopper", "Swimmer", "Humanoid"])
def test_env_pickles_mid_episode_and_the_copy_goes_on_bit_for_bit(name):
    """A task whose model has a ``trackcom`` camera (7 of the 11: its ``track`` was a closure,
    ``Can't pickle local object '_camera.<locals>.track'``) pickles with the standard pickler in
    mid-episode, through ``gymnasium.make``'s wrappers, and the copy continues as the original:
    the same observations, rewards, ends and infos, bit for bit, for the same actions (through a
    reset too, the generator travelling with it); its tracking camera still follows the model."""
    env = gym.make(f"tumble/{name}-v5", render_mode="rgb_array")
    env.reset(seed=4)
    rng = np.random.default_rng(0)
    space = env.action_space
    for _ in range(15):
        env.step(rng.uniform(space.low, space.high).astype(np.float32))
    copy = pickle.loads(pickle.dumps(env))
    ends = 0
    for _ in range(40):
        a = rng.uniform(space.low, space.high).astype(np.float32)
        one, two = env.step(a), copy.step(a)
        assert np.array_equal(one[0], two[0]) and one[1:4] == two[1:4]
        assert one[4].keys() == two[4].keys() and all(np.array_equal(one[4][k], two[4][k]) for k in one[4])
        if one[2] or one[3]:
            ends += 1
            assert np.array_equal(env.reset()[0], copy.reset()[0])
    assert np.array_equal(env.render(), copy.render())
    # the model's tracking camera came along and follows the copy's bodies: the same picture
    mine, theirs = env.unwrapped, copy.unwrapped
    tracking = [k for k, c in theirs.robot.cameras.items() if callable(c.track)]
    assert tracking
    for k in tracking:
        assert theirs.robot.cameras[k].track.robot is theirs.robot
        image = theirs.robot.cameras[k].capture(theirs.world).rgb
        assert np.array_equal(image, mine.robot.cameras[k].capture(mine.world).rgb) and image.std() > 0


def test_vector_env_pickles_and_goes_on_bit_for_bit():
    """The same for a ``ModelVectorEnv`` of 3 hoppers (its template's camera held the closure)."""
    venv = te.ModelVectorEnv(te.Hopper, 3, max_episode_steps=30)
    venv.reset(seed=1)
    rng = np.random.default_rng(2)
    for _ in range(10):
        venv.step(rng.uniform(-1, 1, (3, 3)).astype(np.float32))
    copy = pickle.loads(pickle.dumps(venv))
    for _ in range(30):
        a = rng.uniform(-1, 1, (3, 3)).astype(np.float32)
        one, two = venv.step(a), copy.step(a)
        for x, y in zip(one[:4], two[:4]):
            assert np.array_equal(x, y)


def _same_info(mine: dict, ref: dict):
    """``mine`` is ``ref``: the same keys in the same order, each array of the same dtype, shape
    and bits."""
    assert list(mine) == list(ref)
    for key in ref:
        a, b = np.asarray(mine[key]), np.asarray(ref[key])
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), key


@pytest.mark.parametrize("name, n, steps, limit, seed", [
    ("Hopper", 8, 200, 40, 5),
    ("Humanoid", 3, 60, 20, 2),
    ("InvertedPendulum", 4, 40, 7, 1),
])
def test_vector_info_equals_sync_vector_envs_on_autoreset_steps(name, n, steps, limit, seed):
    """``ModelVectorEnv.step`` returns Gymnasium's ``SyncVectorEnv`` (NEXT_STEP) infos of the same
    single environments bit for bit, keys, order, masks and dtypes: a copy restarting reports its
    reset's info (the hoppers' x_position and z_distance_from_origin, the humanoid's positions,
    distance and tendons; they were masked out, 144 (copy, key) entries over these 200 hopper
    steps), a copy that stepped its step's info; with episodes ended by terminations and the
    limit (counted). Observations, rewards and ends are compared too."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv
    from gymnasium.wrappers import TimeLimit

    task = getattr(te, name)
    venv = te.ModelVectorEnv(task, n, max_episode_steps=limit)
    ref = SyncVectorEnv([lambda: TimeLimit(task(), limit) for _ in range(n)], autoreset_mode=AutoresetMode.NEXT_STEP)
    o1, i1 = venv.reset(seed=seed)
    o2, i2 = ref.reset(seed=seed)
    assert np.array_equal(o1, o2)
    _same_info(i1, i2)
    rng = np.random.default_rng(1)
    high = venv.single_action_space.high
    restarts = partial = 0
    for _ in range(steps):
        a = (rng.uniform(-1, 1, (n, *high.shape)) * high).astype(np.float32)
        restarting = venv._ended.copy()
        one, two = venv.step(a), ref.step(a)
        for x, y in zip(one[:4], two[:4]):
            assert np.array_equal(x, y)
        _same_info(one[4], two[4])
        restarts += restarting.sum()
        partial += restarting.any() and not restarting.all()
    assert restarts >= {"Hopper": 60, "Humanoid": 6, "InvertedPendulum": 20}[name]
    assert partial >= 3
