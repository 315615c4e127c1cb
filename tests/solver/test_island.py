"""Islands and sleeping (tumble.solver.island) on synthetic arrays, and ``SleepState.update``
on a small World's packed state (no Simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumble as tb
from tumble.solver.island import (
    ANGULAR_SLEEP_TOLERANCE,
    LINEAR_SLEEP_TOLERANCE,
    TIME_TO_SLEEP,
    SleepState,
    contact_mask,
    coupling_pairs,
    driven_bodies,
    find_islands,
)

DT = 1.0 / 240.0
STEPS_TO_SLEEP = round(TIME_TO_SLEEP / DT)  # 120


def ints(*values):
    return np.array(values, dtype=np.int64)


# ---------------------------------------------------------------------- islands
def test_chain_of_contacts_and_a_joint_pair_make_islands():
    # 0 fixed ground; 1-2-3 a chain of contacts; 4-5 a joint; 6 alone
    moving = np.array([False, True, True, True, True, True, True])
    island = find_islands(ints(1, 3), ints(2, 2), moving, ints(4, 5).reshape(1, 2))
    assert island.dtype == np.int64 and island.shape == (7,)
    assert island.tolist() == [-1, 1, 1, 1, 4, 4, 6]


def test_fixed_bodies_do_not_join_islands():
    # bodies 1 and 2 both rest on the fixed ground 0, and 3 hangs from the world by a joint (-1)
    moving = np.array([False, True, True, True])
    island = find_islands(ints(0, 2), ints(1, 0), moving, ints(-1, 3).reshape(1, 2))
    assert island.tolist() == [-1, 1, 2, 3]


def test_island_ids_are_the_smallest_index_whatever_the_pair_order():
    rng = np.random.default_rng(3)
    n = 40
    moving = rng.random(n) > 0.2
    a = rng.integers(0, n, 60)
    b = rng.integers(0, n, 60)
    ref = find_islands(a, b, moving)
    for _ in range(5):
        order = rng.permutation(60)
        swap = rng.random(60) > 0.5
        aa = np.where(swap, b, a)[order]
        bb = np.where(swap, a, b)[order]
        assert np.array_equal(find_islands(aa, bb, moving), ref)
    # each id is the smallest member of its component, and components are closed under the pairs
    for i in range(n):
        if moving[i]:
            assert ref[i] == np.flatnonzero(ref == ref[i]).min()
        else:
            assert ref[i] == -1
    for x, y in zip(a, b):
        if moving[x] and moving[y]:
            assert ref[x] == ref[y]


def test_no_contacts_every_moving_body_is_its_own_island():
    moving = np.array([True, False, True])
    assert find_islands(ints(), ints(), moving, np.zeros((0, 2), np.int64)).tolist() == [0, -1, 2]


# ---------------------------------------------------------------------- timers and sleep
def rest(state, moving, speed, a, b, steps, pairs=None, angular=None):
    """``steps`` updates at the given speeds; the velocities of sleeping bodies are zero (as the
    lead's step leaves them)."""
    speed = np.asarray(speed, dtype=float)
    angular = np.zeros_like(speed) if angular is None else np.asarray(angular, dtype=float)
    for _ in range(steps):
        s = np.where(state.awake, speed, 0.0)
        w = np.where(state.awake, angular, 0.0)
        state.update_arrays(moving, s, w, a, b, DT, pairs)
    return state


def test_timer_grows_while_still_and_resets_when_moving():
    moving = np.array([False, True])
    st = SleepState(2)
    rest(st, moving, [0.0, 0.01], ints(0), ints(1), 10)
    assert st.sleep_timer[1] == pytest.approx(10 * DT)
    assert st.sleep_timer[0] == 0.0
    rest(st, moving, [0.0, 2 * LINEAR_SLEEP_TOLERANCE], ints(0), ints(1), 1)
    assert st.sleep_timer[1] == 0.0
    rest(st, moving, [0.0, 0.0], ints(0), ints(1), 3, angular=[0.0, 2 * ANGULAR_SLEEP_TOLERANCE])
    assert st.sleep_timer[1] == 0.0
    assert ANGULAR_SLEEP_TOLERANCE == pytest.approx(math.radians(2.0))


def test_body_at_rest_sleeps_after_time_to_sleep_and_not_before():
    moving = np.array([False, True])
    st = SleepState(2)
    rest(st, moving, [0.0, 0.001], ints(0), ints(1), STEPS_TO_SLEEP - 1)
    assert st.awake.all()
    rest(st, moving, [0.0, 0.001], ints(0), ints(1), 1)
    assert st.awake.tolist() == [True, False]  # fixed bodies count as awake
    assert st.fell_asleep.tolist() == [False, True]
    assert st.sleeping.tolist() == [False, True]
    # it stays asleep while nothing touches it
    rest(st, moving, [0.0, 0.0], ints(0), ints(1), 50)
    assert st.awake.tolist() == [True, False] and not st.woke.any()


def test_an_island_sleeps_only_together():
    # 1 rests on 2 which rests on the ground; 1 keeps moving for a while
    moving = np.array([False, True, True])
    a, b = ints(0, 2), ints(2, 1)
    st = SleepState(3)
    rest(st, moving, [0.0, 0.2, 0.0], a, b, 200)
    assert st.awake.all()
    assert st.sleep_timer[2] == pytest.approx(200 * DT) and st.sleep_timer[1] == 0.0
    rest(st, moving, [0.0, 0.0, 0.0], a, b, STEPS_TO_SLEEP - 1)
    assert st.awake.all()  # 2 has waited long enough, 1 not yet
    rest(st, moving, [0.0, 0.0, 0.0], a, b, 1)
    assert st.sleeping.tolist() == [False, True, True]
    assert st.sleeping_island.tolist() == [-1, 1, 1]


def test_separate_islands_sleep_separately():
    moving = np.array([False, True, True])
    a, b = ints(0, 0), ints(1, 2)  # both on the ground, not touching each other
    st = SleepState(3)
    rest(st, moving, [0.0, 0.0, 0.3], a, b, STEPS_TO_SLEEP)
    assert st.sleeping.tolist() == [False, True, False]


def test_awake_body_touching_a_sleeping_island_wakes_it_whole():
    moving = np.array([False, True, True, True])
    a, b = ints(0, 1), ints(1, 2)  # island {1, 2} on the ground; 3 falls from above
    st = SleepState(4)
    rest(st, moving, [0.0, 0.0, 0.0, 3.0], a, b, STEPS_TO_SLEEP)
    assert st.sleeping.tolist() == [False, True, True, False]
    # 3 lands on 2 only: 1 wakes too, though the lead may no longer detect the 1-2 contact
    st.update_arrays(moving, [0.0, 0.0, 0.0, 3.0], np.zeros(4), ints(0, 3), ints(1, 2), DT)
    assert st.awake.all()
    assert st.woke.tolist() == [False, True, True, False]
    assert st.sleep_timer.tolist() == [0.0, 0.0, 0.0, 0.0]


def test_contact_with_only_fixed_bodies_does_not_wake():
    moving = np.array([False, True, False])
    st = SleepState(3)
    rest(st, moving, [0.0, 0.0, 0.0], ints(0, 2), ints(1, 1), STEPS_TO_SLEEP + 5)
    assert st.sleeping.tolist() == [False, True, False]


def test_joint_to_an_awake_body_wakes_and_keeps_the_island_awake():
    moving = np.array([True, True])
    st = SleepState(2)
    rest(st, moving, [0.0, 0.0], ints(), ints(), STEPS_TO_SLEEP)
    assert st.sleeping.all()
    st.wake([0])
    assert st.awake.tolist() == [True, False]  # not joined yet: its own island
    pair = ints(0, 1).reshape(1, 2)
    st.update_arrays(moving, [0.5, 0.0], np.zeros(2), ints(), ints(), DT, pair)
    assert st.awake.all() and st.woke.tolist() == [False, True]


def test_wake_wakes_the_whole_sleeping_island_and_resets_its_timers():
    moving = np.array([False, True, True, True])
    st = SleepState(4)
    rest(st, moving, np.zeros(4), ints(0, 1, 0), ints(1, 2, 3), STEPS_TO_SLEEP)
    assert st.sleeping.tolist() == [False, True, True, True]
    st.wake(2)
    assert st.sleeping.tolist() == [False, False, False, True]  # 3 is another island
    assert st.sleep_timer[1] == 0.0 and st.sleep_timer[2] == 0.0
    st.wake(np.array([False, False, False, True]))
    assert st.awake.all()


def test_a_velocity_found_on_a_sleeping_body_wakes_its_island():
    moving = np.array([True, True])
    st = SleepState(2)
    rest(st, moving, [0.0, 0.0], ints(0), ints(1), STEPS_TO_SLEEP)
    assert st.sleeping.all()
    st.update_arrays(moving, [0.0, 0.0], [0.0, 1e-6], ints(), ints(), DT)  # user set omega of 1
    assert st.awake.all()


def test_allow_sleep_false_keeps_a_body_and_its_island_awake():
    moving = np.array([False, True, True])
    st = SleepState(3)
    st.set_allow_sleep([2], False)
    rest(st, moving, np.zeros(3), ints(1), ints(2), 3 * STEPS_TO_SLEEP)
    assert st.awake.all()
    st.set_allow_sleep([2], True)
    rest(st, moving, np.zeros(3), ints(1), ints(2), STEPS_TO_SLEEP)
    assert st.sleeping.tolist() == [False, True, True]
    st.set_allow_sleep(1, False)  # forbidding wakes the island
    assert st.awake.all()


def test_world_switch_off_wakes_everything_and_stops_the_timers():
    moving = np.array([True, True])
    st = SleepState(2)
    rest(st, moving, np.zeros(2), ints(), ints(), STEPS_TO_SLEEP)
    assert st.sleeping.all()
    st.enabled = False
    rest(st, moving, np.zeros(2), ints(), ints(), 2 * STEPS_TO_SLEEP)
    assert st.awake.all() and (st.sleep_timer == 0.0).all()


def test_contact_mask_keeps_contacts_with_an_awake_moving_body():
    moving = np.array([False, True, True, True])
    awake = np.array([True, True, False, False])
    a = ints(0, 0, 2, 1, 0)
    b = ints(1, 2, 3, 2, 3)
    assert contact_mask(a, b, awake, moving).tolist() == [True, False, False, True, False]
    assert contact_mask(ints(), ints(), awake, moving).shape == (0,)


def test_state_round_trip_and_resize():
    moving = np.array([False, True, True])
    st = SleepState(3)
    rest(st, moving, np.zeros(3), ints(1), ints(2), STEPS_TO_SLEEP)
    st.set_allow_sleep(0, False)
    saved = st.state()
    resting = {"resting_" + name for name, _dtype, _shape in SleepState.RESTING_FIELDS}
    assert set(saved) == {"sleep_timer", "awake", "allow_sleep", "sleeping_island"} | resting
    other = SleepState()
    other.set_state(saved)
    for k in SleepState.STATE_KEYS:
        assert np.array_equal(getattr(other, k), saved[k])
    for k in resting:  # the contacts kept for sleeping islands (none here: no step made any)
        assert np.array_equal(other.resting[k[len("resting_"):]], saved[k])
    # the restored island wakes whole
    other.update_arrays(moving, [0.0, 0.0, 0.0], np.zeros(3), ints(0), ints(2), DT)
    assert other.sleeping.tolist() == [False, True, True]
    other.wake(1)
    assert other.awake.all()
    other.resize(5)
    assert other.awake.tolist() == [True] * 5 and other.allow_sleep.tolist() == [False] + [True] * 4
    with pytest.raises(ValueError):
        other.set_state({"sleep_timer": np.zeros(2), "awake": np.ones(3, bool), "allow_sleep": np.ones(3, bool)})


# ---------------------------------------------------------------------- on a World's state
def two_box_world():
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 0.5), name="low")
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 1.5), name="high")
    return w


def test_update_reads_speeds_from_the_state_and_zeroes_the_momenta_of_sleepers():
    w = two_box_world()
    w.body("low").v = (0.01, 0.0, 0.0)
    w.body("high").omega = (0.0, 0.0, 0.01)
    Y = w.pack()
    st = SleepState()
    a, b = ints(0, 1), ints(1, 2)
    for _ in range(STEPS_TO_SLEEP):
        st.update(w, Y, a, b, DT)
    assert st.speed[1] == pytest.approx(0.01) and st.angular_speed[2] == pytest.approx(0.01)
    assert st.sleeping.tolist() == [False, True, True]
    assert np.all(Y[1:, 7:] == 0.0) and np.array_equal(Y[:, :7], w.pack()[:, :7])
    # an impulse on one box (P changed in the state) wakes both
    Y[2, 7] = 1.0
    st.update(w, Y, ints(), ints(), DT)
    assert st.awake.all() and st.woke.tolist() == [False, True, True]


def test_update_uses_joints_and_springs_and_keeps_driven_bodies_awake():
    w = two_box_world()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(3, 0, 0.1), name="ball")
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(5, 0, 0.1), name="pushed")
    w.add_joint(tb.BallJoint(body_a="low", body_b="ball", anchor=(1, 0, 0.3)))
    w.add_force(tb.Spring(body_a="high", body_b=None, stiffness=1.0, rest_length=1.0))
    w.add_force(tb.ConstantForce(body="pushed", force=(0.0, 0.0, 0.0)))
    pairs = coupling_pairs(w)
    assert pairs.tolist() == [[1, 3], [2, -1]]
    assert driven_bodies(w).tolist() == [False, False, False, False, True]
    Y = w.pack()
    st = SleepState()
    for _ in range(STEPS_TO_SLEEP):
        # "low" rests on the ground (an island sleeps only held by something that does not move:
        # "high" hangs on its spring to the world)
        st.update(w, Y, ints(0), ints(1), DT)
    assert st.island.tolist() == [-1, 1, 2, 1, 4]
    assert st.sleeping.tolist() == [False, True, True, True, False]
