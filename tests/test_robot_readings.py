"""A robot's joint readings before the first step (``Robot.joint_states`` -> ``present_readings``)
read its own joints, not every joint of the world: a vector environment of n copies read each
copy's over all n copies' joints (n^2 work: its first step took 10 s at 512 pendulums, 201 s at
2048; an RL audit, session 43; 0.65 s and 1.8 s after)."""

import tumble as tb
from tumble.solver import joints as solver_joints

CARTPOLE = "examples/robots/cartpole.xml"


def test_a_copys_readings_before_the_first_step_are_its_own_joints_and_the_same_values(monkeypatch):
    """Eight copies of the cartpole in one world, each turned: each copy's ``joint_states`` before
    the first step builds a solver of its own joints (2), not the world's 16, and reads the same
    values as the readings of the whole world's joints (bit for bit: the same kernel on the same
    rows)."""
    world = tb.World(gravity=(0, 0, -9.81))
    robots = [tb.load_mjcf(world, CARTPOLE, name=f"c{k}", position=(2.0 * k, 0, 0),
                           joint_positions={"hinge": 0.1 * k, "slider": -0.05 * k}) for k in range(8)]
    sim = tb.Simulator(world, dt=1 / 240)
    whole = solver_joints.present_readings(world)
    index = {id(j): k for k, j in enumerate(world.joints)}
    built = []
    original = solver_joints.JointSolver._build
    monkeypatch.setattr(solver_joints.JointSolver, "_build", lambda self, joints: (built.append(len(joints)),
                                                                                  original(self, joints))[1])
    for k, robot in enumerate(robots):
        states = robot.joint_states(sim)
        for name, (q, rate) in states.items():
            row = index[id(robot.joints[name])]
            assert (q, rate) == (whole["position"][row], whole["rate"][row])
        assert abs(states["hinge"][0] - 0.1 * k) < 1e-12 and abs(states["slider"][0] + 0.05 * k) < 1e-12
    # (the Simulator's own, empty until its first step, is built with no joints)
    assert [b for b in built if b] == [len(robots[0].joints)] * len(robots)
