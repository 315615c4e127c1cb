"""tumble.envs against Gymnasium's API around the task: the frame rate a video plays at
(``metadata["render_fps"]``), the ``"human"`` render mode, pickling an environment mid-episode,
and a vector environment's info on autoreset steps (compared with Gymnasium's own
``SyncVectorEnv`` of the same single environments)."""

import pickle

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import tumble.envs as te  # noqa: E402


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
