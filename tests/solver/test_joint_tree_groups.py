"""The tree solve's extra limit sweeps are decided per group of joints sharing moving bodies
(``joint_tree.tree_sweeps_kernel``, ``JointSolver._groups``): each robot of a world ends its steps
as it would alone, bit for bit, whatever the others' limits do.

Compared with: the same robot stepped alone (the reference is the engine itself: the property is
independence, so the comparison is exact)."""

import numpy as np
import pytest

import tumble as tb
from tumble.solver.joints import ACCURATE

# a two-link arm whose elbow has a narrow range: swung hard, it strikes it (the limit rows take
# impulses, so the tree sweeps on until they settle); no geom touches anything. Its shoulder is
# damped: a Gauss-Seidel row every sweep, so an arm swept more times than alone ends elsewhere (the
# limits, solved through the tree since session 35, leave an arm without them as it was)
ARM = """<mujoco model="arm"><compiler angle="radian"/><worldbody>
  <body name="upper" pos="0 0 2"><joint name="shoulder" type="hinge" axis="0 1 0" damping="0.05"/>
    <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03" contype="0" conaffinity="0" mass="1"/>
    <body name="lower" pos="0.5 0 0"><joint name="elbow" type="hinge" axis="0 1 0" range="-0.3 0.3"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" contype="0" conaffinity="0" mass="0.5"/>
    </body></body></worldbody></mujoco>"""

NOTHING = tb.CollisionFilter(category=1 << 31, mask=1 << 30)  # touches nothing (tumble.envs' filter)


def arms(path, starts):
    """A world of one arm per entry of ``starts`` ((shoulder, elbow) rad, rates (2,) rad/s), all at
    one place, the tree solve (``ACCURATE``); stepped 0.5 s at dt 1/240. Returns the world, the
    robots and the first arm's largest elbow angle over the run (rad)."""
    world = tb.World(gravity=(0, 0, -9.81))
    robots = [tb.load_mjcf(world, path, name=f"arm{k}", collision_filter=NOTHING) for k in range(len(starts))]
    sim = tb.Simulator(world, dt=1 / 240, joint_settings=ACCURATE)
    for robot, (q, qd) in zip(robots, starts):
        robot.kinematics.set_state(np.array(q), np.array(qd), sim=sim)
    elbow = 0.0
    for _ in range(120):
        sim.step(1)
        elbow = max(elbow, abs(robots[0].joint_states(sim)["elbow"][0]))
    return world, robots, elbow


def compare(path, starts):
    """Whether each arm of ``starts`` ends with the bits it ends with alone (x, q, P, L)."""
    together, robots, elbow = arms(path, starts)
    same = []
    for k, start in enumerate(starts):
        alone, (robot,), _ = arms(path, [start])
        mine = [robots[k].links[name].index for name in ("upper", "lower")]
        its = [robot.links[name].index for name in ("upper", "lower")]
        same.append(all(np.array_equal(getattr(together, name)[mine], getattr(alone, name)[its])
                        for name in ("x", "q", "P", "L")))
    return same, elbow


STARTS = [((0.3, 0.25), (8.0, 12.0)), ((-0.2, 0.1), (-3.0, 2.0)), ((0.0, 0.0), (0.0, 0.0))]


def test_each_arm_ends_as_it_would_alone_whatever_the_other_arms_limits_do(tmp_path, monkeypatch):
    """Three arms in one world: one swung hard into its elbow's limit (0.3 rad: reached), one swung
    the other way, one hanging still. Each ends with the bits it ends with alone, though the first
    one's limit strikes keep the sweeps going for it. With one settling test over the world (the
    code before, put back here by making every joint one group) the arms do not: the test can
    tell (measured on tumble.envs' Reacher copies: 1e-7 apart after one step)."""
    from tumble.solver.joints import JointSolver

    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    same, elbow = compare(path, STARTS)
    assert elbow > 0.29  # the limit was struck
    assert same == [True, True, True]

    grouped = JointSolver._groups

    def one_group(self, moving):
        grouped(self, moving)
        self.joint_group[self.joint_group >= 0] = 0
        self.body_group[self.body_group >= 0] = 0
        self._group_scratch = tuple(a[:1] if a.ndim == 1 and a.shape[0] > 1 and a.dtype != np.int64 else a
                                    for a in self._group_scratch)

    monkeypatch.setattr(JointSolver, "_groups", one_group)
    same_before, _ = compare(path, STARTS)
    assert not all(same_before)


def _many_arms(path, count, threads=None):
    """``arms`` with ``count`` arms (STARTS over and over, the rates scaled a little per arm), its
    joint solver's group mode, and the state (x, q, P, L) at the end."""
    import numba

    starts = [(q, tuple(r * (1 + 0.01 * k) for r in qd)) for k, (q, qd) in
              ((k, STARTS[k % len(STARTS)]) for k in range(count))]
    before = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(threads)
    try:
        world, _, elbow = arms(path, starts)
    finally:
        numba.set_num_threads(before)
    return world, elbow


@pytest.fixture
def group_modes(monkeypatch):
    """The list of the group modes (``JointSolver._groups_table[0]``: 1 side by side, 0 serial) of
    every joint solver built while the test runs, in order."""
    from tumble.solver import joints as J

    modes = []
    build = J.JointSolver._group_tables

    def record(self, moving):
        build(self, moving)
        modes.append(self._groups_table[0])

    monkeypatch.setattr(J.JointSolver, "_group_tables", record)
    return modes


def test_groups_swept_side_by_side_end_with_the_serial_sweeps_bits(tmp_path, monkeypatch, group_modes):
    """With enough tree nodes (``GROUP_THREADS_MIN_NODES``) the groups of a world are swept side by
    side on the threads (``joint_tree._tree_sweeps_groups``): 16 arms (64 nodes), their elbows
    striking their limits, end with the bits of the serial sweep over the world (the threshold
    raised past them), on one thread or two. Compared with: the serial sweep itself (the property
    is that the side-by-side sweep reorders nothing within a group, so the comparison is exact)."""
    from tumble.solver import joints as J

    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    modes = group_modes
    side, elbow = _many_arms(path, 16)
    assert elbow > 0.29  # the limits were struck: extra sweeps, and limit rows through the tree
    assert modes == [1]
    one_thread, _ = _many_arms(path, 16, threads=1)
    monkeypatch.setattr(J, "GROUP_THREADS_MIN_NODES", 10**9)
    serial, _ = _many_arms(path, 16)
    assert modes[1:] == [1, 0]
    for name in ("x", "q", "P", "L"):
        assert np.array_equal(getattr(side, name), getattr(serial, name))
        assert np.array_equal(getattr(one_thread, name), getattr(serial, name))


def test_groups_are_swept_apart_only_when_nothing_outside_a_group_can_move():
    """``_groups_apart``: a joint outside every group, or one whose other end is outside its group and
    can move (a sleeping body keeps its mass: two groups' rows could both push it), sends the solve
    back to the serial sweep over the world; the world and fixed ends (no inverse mass or inertia) do
    not."""
    from tumble.solver.joint_tree import _groups_apart

    joint_a = np.array([-1, 0, 2], dtype=np.int64)  # joint 0: world - body 0; joint 1: 0 - 1; joint 2: 2 - 3
    joint_b = np.array([0, 1, 3], dtype=np.int64)
    enabled = np.ones(3, dtype=bool)
    joint_group = np.array([0, 0, 1], dtype=np.int64)
    body_group = np.array([0, 0, 1, -1], dtype=np.int64)  # body 3 moves in no group (asleep, or fixed)
    inv_mass = np.array([1.0, 1.0, 1.0, 0.0])
    I_inv = np.zeros((4, 3, 3))
    I_inv[:3] = np.eye(3)
    args = (joint_a, joint_b, enabled, joint_group, body_group)
    assert _groups_apart(*args, inv_mass, I_inv)  # body 3 fixed
    inv_mass[3] = 1.0  # body 3 asleep: it has its mass
    assert not _groups_apart(*args, inv_mass, I_inv)
    inv_mass[3] = 0.0
    I_inv[3] = np.eye(3)  # no inverse mass but an inverse inertia: it can turn
    assert not _groups_apart(*args, inv_mass, I_inv)
    I_inv[3] = 0.0
    joint_group[2] = -1
    assert not _groups_apart(*args, inv_mass, I_inv)  # an enabled joint in no group
    enabled[2] = False
    assert _groups_apart(*args, inv_mass, I_inv)  # a disabled one is never swept


def test_ragdolls_swept_side_by_side_end_with_the_serial_sweeps_bits(monkeypatch, group_modes):
    """The same for the limits of ball joints, solved through the tree since session 37 (each joint's
    cone row and twist row, ``tree_limits_kernel``'s rows j and J + j, their responses taken anew
    after each factorization: ``_sweep_group`` clears both): five ragdolls (tumble.scenes.ragdolls,
    55 tree nodes: hips, shoulders, waist and neck ball joints with cones and twists, hinged knees
    and elbows) dropped 1.5 s into a heap, side by side (mode 1) and by the serial sweep (the
    threshold raised past them), end with the same bits."""
    from tumble.scenes.ragdolls import ragdolls
    from tumble.solver import joints as J

    modes = group_modes

    def heap():
        world, _ = ragdolls(5, 0)
        sim = tb.Simulator(world, dt=1 / 60, joint_settings=ACCURATE)
        sim.step(90)
        struck = np.abs(sim.soft_step.joints.axial_impulse[:, [2, 3, 5, 6]]).max()  # the limits' impulses
        return world, struck

    side, struck = heap()
    assert struck > 0.0 and modes[-1] == 1
    monkeypatch.setattr(J, "GROUP_THREADS_MIN_NODES", 10**9)
    serial, _ = heap()
    assert modes[-1] == 0
    for name in ("x", "q", "P", "L"):
        assert np.array_equal(getattr(side, name), getattr(serial, name))
