"""Determinism is a tested contract (STYLE 5.6 rule 6, docs/reliability.md).

* every example scene and the demo end in the golden state hash (the compiled path users run);
* two CLI runs of each give the same ``state_hash`` in summary.json and byte-identical trajectory files;
* the parallel kernel gives the same bits for any thread count;
* the stage-by-stage path (``TUMBLE_VALIDATE=1``) gives the same bits as the compiled path.

After a change meant to alter the bits: ``PYTHONPATH=src python -m tests.determinism.update_golden``.
"""

import json
import platform

import numba
import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.cli import main as cli_main
from tumble.scene import load_scene

from ..conftest import PINNED_BLAS_CORE, _cpu_has
from ..threads import numba_threads
from .scenes import GOLDEN, blas_core, final_hash, scene_paths

SCENES = scene_paths()


@pytest.mark.skipif(not _cpu_has("avx2", "fma"), reason="the golden hashes are those of OpenBLAS's Haswell kernels")
def test_the_suite_runs_the_pinned_blas_kernels():
    """The golden hashes were recorded with OpenBLAS's Haswell kernels (tests/conftest.py pins
    them before NumPy loads): on an AVX-512 machine its own choice rounds NumPy's small matrix
    products differently and two scenes' hashes change (platforms, wrecking_ball: measured)."""
    assert blas_core() == PINNED_BLAS_CORE


@pytest.mark.parametrize("name", sorted(SCENES))
def test_golden_state_hash(name):
    golden = json.loads(GOLDEN.read_text())
    assert final_hash(SCENES[name]) == golden[name], (
        f"{name}: the final state changed (NumPy's OpenBLAS kernels: {blas_core()}); if meant, run "
        "`PYTHONPATH=src python -m tests.determinism.update_golden`")


@pytest.mark.parametrize("name", sorted(SCENES))
def test_two_cli_runs_give_the_same_state_hash_and_bytes(name, tmp_path, capsys):
    summaries, files = [], []
    for k in range(2):
        out = tmp_path / f"run{k}"
        assert cli_main(["run", str(SCENES[name]), "--out", str(out), "--no-progress"]) == 0
        summaries.append(json.loads((out / "summary.json").read_text()))
        files.append((out / "trajectory.npz").read_bytes())
    capsys.readouterr()
    a, b = (s["run"] for s in summaries)
    assert a["status"] == b["status"] == "completed"
    assert a["state_hash"] == b["state_hash"] == json.loads(GOLDEN.read_text())[name]
    assert files[0] == files[1]


# the scenes whose bits once depended on OpenBLAS's kernels (set-up products through ``@``, ``norm``,
# ``inv``; measured 2026-12-04) and one of each other kind of set-up: a Convex cell, a keyframed
# path, particles, a URDF robot, compounds, hulls, joints, the demo
CROSS_KERNEL_SCENES = ("bowling", "demo", "dice", "particles", "platforms", "ring_toss", "robot_arm", "wrecking_ball")


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64") or blas_core() is None,
                    reason="OpenBLAS's x86 kernels only")
def test_golden_scenes_do_not_depend_on_the_blas_kernels():
    """The golden scenes run in a process whose OpenBLAS runs its oldest x86 kernels (Katmai's, SSE:
    ``OPENBLAS_CORETYPE=Prescott``) end in the golden hashes, recorded with Haswell's (AVX2, FMA):
    tumble's set-up and per-step Python do their small products without BLAS (``math3d.mat_vec``),
    so a scene gives the same bits on an AVX-512 machine (SkylakeX's kernels) as on an AVX2 one.
    Before that, platforms and wrecking_ball ended elsewhere with SkylakeX's kernels, and six scenes
    with Katmai's (measured). Would fail if a set-up product went back through BLAS."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    script = ("import json, sys; from tests.determinism.scenes import blas_core, final_hash, scene_paths; "
              "paths = scene_paths(); names = sys.argv[1:]; "
              "print(json.dumps({'core': blas_core(), 'hashes': {n: final_hash(paths[n]) for n in names}}))")
    env = dict(os.environ, OPENBLAS_CORETYPE="Prescott")
    env["PYTHONPATH"] = os.pathsep.join([str(root / "src"), env.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-c", script, *CROSS_KERNEL_SCENES], env=env, cwd=root,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["core"] not in (None, PINNED_BLAS_CORE)  # the other kernels really ran
    golden = json.loads(GOLDEN.read_text())
    assert result["hashes"] == {name: golden[name] for name in CROSS_KERNEL_SCENES}


def _many_free_bodies(n=640):
    w = tb.World(gravity=(0, 0, -9.81))
    w.collisions = False  # overlapping boxes: this test is about the free-flight kernels
    rng = np.random.default_rng(7)
    for i in range(n):
        w.add_body(tb.Box(size=tuple(rng.uniform(0.1, 1.0, 3))), mass=float(rng.uniform(0.5, 2)),
                   position=tuple(rng.normal(size=3)), angular_velocity=tuple(rng.normal(scale=5, size=3)))
    w.add_force(tb.Drag(linear=0.1, angular_quadratic=0.01))
    return w


def test_parallel_kernel_bits_do_not_depend_on_the_thread_count():
    from tumble import integrators as K

    assert 640 >= K.PARALLEL_MIN_BODIES
    hashes = []
    for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
        with numba_threads(threads):
            w = _many_free_bodies()
            tb.Simulator(w).run(0.5)
            hashes.append(state_hash(w))
    serial = _many_free_bodies()
    sim = tb.Simulator(serial)
    for _ in range(12):  # the serial kernel on chunks below the parallel threshold gives the same rows
        Y = serial.pack()
        for start in range(0, len(Y), 256):
            sub = np.ascontiguousarray(Y[start:start + 256])
            K.step_bodies_kernel(sim.integrator_id, serial.layout_id, sim.dt, 10, sub, *[a[start:start + 256] for a in (
                serial.mass, serial.inv_mass, serial.inertia_body_inv, serial.principal_q, serial.principal_moments, serial.moving)],
                serial.gravity, *_unary_tables(serial, start, start + 256))
            Y[start:start + 256] = sub
        serial.unpack(Y)
        sim.step_index += 10
        serial.t = sim.step_index * sim.dt
    hashes.append(state_hash(serial))
    assert len(set(hashes)) == 1, hashes


def _unary_tables(world, lo, hi):
    tb_ = world.tables
    start = tb_.uforce_start[lo:hi + 1]
    return tb_.uforce_kind, tb_.uforce_param, start.copy()


@pytest.mark.parametrize("name", sorted(SCENES))
def test_stage_by_stage_validated_path_gives_the_same_bits(name, monkeypatch):
    def run(validate):
        monkeypatch.setenv("TUMBLE_VALIDATE", "1" if validate else "0")
        scene = load_scene(SCENES[name])
        scene.duration = 1.0
        sim = scene.simulator()
        assert sim.validate is validate
        traj = sim.run(scene.duration, scene.frame_rate, progress=False)
        return state_hash(scene.world), traj

    (h1, t1), (h2, t2) = run(False), run(True)
    assert h1 == h2
    assert np.array_equal(t1.position, t2.position) and np.array_equal(t1.orientation, t2.orientation)
