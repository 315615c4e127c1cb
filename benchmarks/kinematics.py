"""The cost of a robot's joint-space queries (``robot.kinematics``) beside the peers' on the same
files, and how far their answers are apart.

- PyBullet's Kuka iiwa (``kuka_iiwa/model.urdf``, 7 hinges, fixed base) against PyBullet:
  ``calculateJacobian``, ``calculateMassMatrix``, ``calculateInverseDynamics``,
  ``calculateInverseKinematics`` (position only; its default: damped least squares, 20 iterations).
- Gym's ``ant.xml`` with its free joint (14 rates) and ``humanoid.xml`` (21 hinges, fixed torso)
  against MuJoCo 3: ``mj_kinematics`` + ``mj_comPos`` + ``mj_jac`` for a Jacobian, ``mj_crb`` +
  ``mj_fullM`` for the mass matrix, ``mj_rne`` for inverse dynamics (each call made whole from
  qpos, as tumble's are).

Each figure is the median over 5 repeats of the mean time of a batch of calls, after a warm-up;
the answers' largest difference is taken at 5 random configurations. Usage:

    PYTHONPATH=src python benchmarks/kinematics.py [--out benchmarks/results/kinematics.md]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

import tumble as tb  # noqa: E402
from report import emit, machine_line  # noqa: E402


def timed(fn, batch=200, repeats=5) -> float:
    """Median over ``repeats`` of the mean seconds of one call of ``fn`` in a batch."""
    fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(batch):
            fn()
        out.append((time.perf_counter() - t0) / batch)
    return statistics.median(out)


def kuka_rows():
    import pybullet as p
    import pybullet_data

    path = os.path.join(pybullet_data.getDataPath(), "kuka_iiwa/model.urdf")
    kin = tb.load_urdf(tb.World(gravity=(0, 0, -9.81)), path, fixed_base=True).kinematics
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    uid = p.loadURDF(path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
    rng = np.random.default_rng(0)
    link, index = "lbr_iiwa_link_7", 6
    q, qd, qdd = rng.uniform(-1, 1, 7), rng.normal(size=7), rng.normal(size=7)
    zeros = [0.0] * 7
    diff = {"jacobian": 0.0, "mass matrix": 0.0, "inverse dynamics": 0.0}
    for _ in range(5):
        qq = rng.uniform(-1.5, 1.5, 7)
        jt, jr = p.calculateJacobian(uid, index, [0.0, 0.0, 0.05], list(qq), zeros, zeros, physicsClientId=client)
        diff["jacobian"] = max(diff["jacobian"], float(np.abs(kin.jacobian(link, (0, 0, 0.05), qq) - np.vstack([jt, jr])).max()))
        M = np.array(p.calculateMassMatrix(uid, list(qq), physicsClientId=client))
        diff["mass matrix"] = max(diff["mass matrix"], float(np.abs(kin.mass_matrix(qq) - M).max()))
        tau = p.calculateInverseDynamics(uid, list(qq), list(qd), list(qdd), physicsClientId=client)
        diff["inverse dynamics"] = max(diff["inverse dynamics"], float(np.abs(kin.inverse_dynamics(qdd, qq, qd) - tau).max()))
    rows = [
        ("kuka (7)", "jacobian", timed(lambda: kin.jacobian(link, (0, 0, 0.05), q)),
         timed(lambda: p.calculateJacobian(uid, index, [0.0, 0.0, 0.05], list(q), zeros, zeros, physicsClientId=client)),
         diff["jacobian"]),
        ("kuka (7)", "mass matrix", timed(lambda: kin.mass_matrix(q)),
         timed(lambda: p.calculateMassMatrix(uid, list(q), physicsClientId=client)), diff["mass matrix"]),
        ("kuka (7)", "inverse dynamics", timed(lambda: kin.inverse_dynamics(qdd, q, qd)),
         timed(lambda: p.calculateInverseDynamics(uid, list(q), list(qd), list(qdd), physicsClientId=client)),
         diff["inverse dynamics"]),
    ]
    # inverse kinematics: reachable targets (the forward kinematics of random poses within the limits)
    targets = []
    for _ in range(20):
        qt = np.array([rng.uniform(c.lower, c.upper) for c in kin.coordinates])
        targets.append(kin.forward_kinematics(qt)[link][0])
    ours, theirs = [], []
    t_ours = t_theirs = 0.0
    for target in targets:
        t0 = time.perf_counter()
        sol = kin.inverse_kinematics(link, target, qpos=np.zeros(7), restarts=3)
        t_ours += time.perf_counter() - t0
        ours.append(sol.position_error)
        for i in range(7):
            p.resetJointState(uid, i, 0.0, physicsClientId=client)
        t0 = time.perf_counter()
        qp = p.calculateInverseKinematics(uid, index, list(target), maxNumIterations=100, residualThreshold=1e-6,
                                          physicsClientId=client)
        t_theirs += time.perf_counter() - t0
        o, _R = kin.forward_kinematics(np.array(qp))[link]
        theirs.append(float(np.linalg.norm(o - target)))
    p.disconnect(client)
    ik = ("kuka (7)", "inverse kinematics (20 reachable points)", t_ours / 20, t_theirs / 20,
          f"miss: tumble median {np.median(ours):.1e} m, max {max(ours):.1e}; PyBullet median {np.median(theirs):.1e} m, "
          f"max {max(theirs):.1e}")
    return rows + [ik]


def mujoco_rows(path, label):
    import mujoco

    kin = tb.load_mjcf(tb.World(gravity=(0, 0, -9.81)), path).kinematics
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)

    def config():
        q = d.qpos.copy() * 0 + m.qpos0
        for c in kin.coordinates:
            if c.kind in ("revolute", "continuous", "prismatic"):
                q[c.qpos] = rng.uniform(-0.5, 0.5)
        return q

    body = m.nbody - 1
    name = m.body(body).name
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    M = np.zeros((m.nv, m.nv))
    res = np.zeros(m.nv)
    q, qd, qdd = config(), rng.normal(size=m.nv), rng.normal(size=m.nv)

    def mj_jacobian():
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jac(m, d, jacp, jacr, d.xipos[body], body)

    def mj_mass():
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_fullM(m, d, M)

    def mj_inverse():
        d.qpos[:], d.qvel[:] = q, qd
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        d.qacc[:] = qdd
        mujoco.mj_rne(m, d, 1, res)

    diff = {"jacobian": 0.0, "mass matrix": 0.0, "inverse dynamics": 0.0}
    for _ in range(5):
        q = config()
        mj_jacobian()
        o, R = kin.forward_kinematics(q)[name]
        J = kin.jacobian(name, R.T @ (d.xipos[body] - o), q)
        diff["jacobian"] = max(diff["jacobian"], float(np.abs(J - np.vstack([jacp, jacr])).max()))
        mj_mass()
        diff["mass matrix"] = max(diff["mass matrix"], float(np.abs(kin.mass_matrix(q) - M).max()))
        mj_inverse()
        diff["inverse dynamics"] = max(diff["inverse dynamics"], float(np.abs(
            kin.inverse_dynamics(qdd, q, qd) - (res + m.dof_armature * qdd)).max()))
    local = np.zeros(3)
    return [
        (label, "jacobian", timed(lambda: kin.jacobian(name, local, q)), timed(mj_jacobian), diff["jacobian"]),
        (label, "mass matrix", timed(lambda: kin.mass_matrix(q)), timed(mj_mass), diff["mass matrix"]),
        (label, "inverse dynamics", timed(lambda: kin.inverse_dynamics(qdd, q, qd)), timed(mj_inverse),
         diff["inverse dynamics"]),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    from mjcf_models import free_ant_file, path_of

    rows = kuka_rows()
    rows += mujoco_rows(free_ant_file(), "ant, free (14)")
    rows += mujoco_rows(path_of("humanoid.xml"), "humanoid (21)")
    lines = [machine_line('median of 5 batches'), "",
             "| model (rates) | query | tumble us | peer us | peer | largest difference |",
             "|---|---|---|---|---|---|"]
    for model, query, ours, theirs, diff in rows:
        peer = "PyBullet" if model.startswith("kuka") else "MuJoCo"
        d = diff if isinstance(diff, str) else f"{diff:.1e}"
        lines.append(f"| {model} | {query} | {ours * 1e6:.1f} | {theirs * 1e6:.1f} | {peer} | {d} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()
