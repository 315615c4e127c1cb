"""The tree solve's extra limit sweeps are decided per group of joints sharing moving bodies
(``joint_tree.tree_sweeps_kernel``, ``JointSolver._groups``): each robot of a world ends its steps
as it would alone, bit for bit, whatever the others' limits do.

Compared with: the same robot stepped alone (the reference is the engine itself: the property is
independence, so the comparison is exact)."""

import numpy as np

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
