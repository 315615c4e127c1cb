"""Balance a cart-pole with LQR from tumble's linearized step (MuJoCo's mjd_transitionFD).

The model, ``examples/robots/cartpole.xml`` (MJCF), stands its pole up in the file's pose, the
unstable equilibrium. ``robot.kinematics.transition_jacobians(sim)`` linearizes one step there:
x' = A x + B u with x = (cart position, pole angle, their rates) and u the cart motor's control.
SciPy's discrete Riccati solver gives the LQR gain G, and a controller applies u = -G x before
every step. Started 0.3 m off centre with the pole 0.15 rad over, the cart swings out, catches
the pole and brings both back. Writes OUT/trajectory.npz (and OUT/trajectory.glb with --gltf)::

    python examples/control/lqr_cartpole.py --out out/cartpole [--gltf]
    tumble view out/cartpole

Checked by tests/physics/test_linearize.py::test_the_lqr_cartpole_example_balances.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.linalg import solve_discrete_are

import tumble as tb
from tumble.solver.joints import JointSettings

MODEL = Path(__file__).resolve().parent.parent / "robots" / "cartpole.xml"
DT = 1 / 240
# LQR weights: the pole's angle 10 times the cart's place, the rates lightly, the push cheaply
Q = np.diag([1.0, 10.0, 0.1, 0.1])
R = np.array([[0.01]])


def load():
    """A world with the cart-pole, its robot, and a simulator (the tree solve: exact joints, whose
    linearization is the rigid one; docs/robots.md)."""
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, str(MODEL))
    sim = tb.Simulator(world, dt=DT, joint_settings=JointSettings(method="tree"))
    return world, robot, sim


def lqr_gain() -> np.ndarray:
    """(1, 4) the LQR gain of the step linearized upright, at rest."""
    _, robot, sim = load()
    lin = robot.kinematics.transition_jacobians(sim)
    P = solve_discrete_are(lin.A, lin.B, Q, R)
    return np.linalg.solve(R + lin.B.T @ P @ lin.B, lin.B.T @ P @ lin.A)


def balance(duration: float = 5.0, cart: float = 0.3, angle: float = 0.15, gain=None):
    """Run the cart-pole from ``cart`` m and ``angle`` rad off upright under u = -G x for ``duration``
    s (``gain`` None: G from ``lqr_gain``; 0: no control). Returns (trajectory, robot, sim, pushes),
    pushes the controls applied, N."""
    G = lqr_gain() if gain is None else gain
    world, robot, sim = load()
    kin = robot.kinematics
    pushes = []

    def control(s):
        x = np.concatenate([kin.qpos(s), kin.qvel()])
        u = float(-(np.atleast_2d(G) @ x)[0]) if np.any(G) else 0.0
        pushes.append(u)
        robot.set_controls(s, {"push": u})

    sim.controller = control
    kin.set_state(np.array([cart, angle]), np.zeros(2), sim=sim)
    traj = sim.run(duration, progress=False)
    return traj, robot, sim, pushes


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/cartpole")
    ap.add_argument("--gltf", action="store_true", help="also write OUT/trajectory.glb")
    args = ap.parse_args()
    traj, robot, sim, pushes = balance()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    traj.save(out / "trajectory.npz")
    if args.gltf:
        from tumble.export.gltf import export_gltf

        export_gltf(traj, out / "trajectory.glb")
    q = robot.kinematics.qpos(sim)
    print(f"after {sim.world.t:.1f} s: cart {q[0]:+.4f} m, pole {q[1]:+.5f} rad; largest push {max(map(abs, pushes)):.2f} N")
    print(f"wrote {out / 'trajectory.npz'}")


if __name__ == "__main__":
    main()
