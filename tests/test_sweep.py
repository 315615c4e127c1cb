"""tumble.sweep: sweeps of scene variants (issue 7).

Scene: the Dzhanibekov box of examples/dzhanibekov.toml, shortened (4 s at a
coarse dt = 1/60 s, 30 frames a second) so that 1000 variants run in about a
second batched. The sweep varies the body-x spin perturbation of the
intermediate-axis spin; the flip time (first sign change of the body-frame y
rate) must fall as the perturbation grows.

Each acceptance item of the issue is one test below:
- test_flip_time_sweep_falls_and_matches_single_runs
- test_local_cluster_and_scheduler_cli_give_the_same_table
- test_killed_worker_loses_no_variant
- test_interrupted_sweep_resumes_to_the_same_table (API) and
  test_cli_sigint_then_resume_gives_the_same_table (CLI, a real SIGINT)
- test_batched_10000_variants_match_separate_runs_bit_for_bit
- test_bad_input_exits_2_with_one_line
"""

from __future__ import annotations

import copy
import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
distributed = pytest.importorskip("distributed")

import tumble as tb
from tumble import checks
from tumble.scene import parse_scene
from tumble.sweep import run_sweep, run_variant, table_for_comparison
from tests.ctrl_c import cli_under_ctrl_c

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
KEY = "bodies.box.angular_velocity[0]"
SPEC = "linspace(0.001, 0.2, 1000)"
METRICS = ["flip_time:box:y", "energy_drift", "final_orientation:box", "final_angular_velocity:box"]
CHUNK = 50


def scene_document() -> dict:
    data = tomllib.loads((ROOT / "examples" / "dzhanibekov.toml").read_text())
    data["simulation"].update(duration=4.0, dt=1.0 / 60.0, frame_rate=30)
    return data


def write_scene(path: Path, sweep: dict | None = None) -> Path:
    data = scene_document()
    lines = ["[simulation]"]
    for k, v in data["simulation"].items():
        lines.append(f"{k} = {json.dumps(v)}")
    b = data["bodies"][0]
    lines += ["", "[[bodies]]", f'name = "{b["name"]}"', 'shape = { type = "box", size = [0.2, 0.6, 1.0] }',
              f"mass = {b['mass']}", f"angular_velocity = {json.dumps(b['angular_velocity'])}", 'angular_velocity_frame = "body"']
    if sweep:
        lines += ["", "[sweep]"] + [f"{k} = {toml_value(v)}" for k, v in sweep.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def toml_value(v) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return json.dumps(v)


def env():
    e = dict(os.environ)
    e["PYTHONPATH"] = str(SRC) + os.pathsep + e.get("PYTHONPATH", "")
    return e


def cli(*args, timeout=120, **kw):
    return subprocess.run([sys.executable, "-m", "tumble.cli", *map(str, args)], capture_output=True, text=True, env=env(),
                          timeout=timeout, check=False, **kw)


def same(a, b, drop=()):
    a, b = table_for_comparison(a), table_for_comparison(b)
    a = a.drop_columns([c for c in drop if c in a.column_names])
    b = b.drop_columns([c for c in drop if c in b.column_names])
    assert a.schema == b.schema
    assert a.num_rows == b.num_rows
    for name in a.column_names:
        x, y = a[name].to_pylist(), b[name].to_pylist()
        if x != y:  # NaN != NaN: compare floats by their bits
            assert np.array_equal(np.array(x, dtype=float), np.array(y, dtype=float), equal_nan=True), name
    return True


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("scene") / "dzhanibekov_short.toml")


@pytest.fixture(scope="module")
def reference(scene_file, tmp_path_factory):
    """The 1000-variant sweep in this process (the executor every other one is compared with)."""
    out = tmp_path_factory.mktemp("reference")
    table = run_sweep(scene_file, vary={KEY: SPEC}, metrics=METRICS, out=out, workers=0, chunk_size=CHUNK, progress=False)
    return table


# ---------------------------------------------------------------------- 1. the flip-time sweep


def _body_rate_y(traj):
    R = np.array([tb.math3d.quat_to_matrix(q) for q in traj.orientation[:, 0]])
    return np.einsum("fji,fj->fi", R, traj.angular_velocity[:, 0])[:, 1]


def test_flip_time_sweep_falls_and_matches_single_runs(reference, scene_file):
    t = reference
    assert t.num_rows == 1000
    assert t["variant"].to_pylist() == list(range(1000))
    assert set(t["status"].to_pylist()) == {"ok"}
    pert = np.array(t[KEY].to_pylist())
    assert np.array_equal(pert, np.linspace(0.001, 0.2, 1000))
    flip = np.array(t["flip_time:box:y"].to_pylist())
    assert np.all(np.isfinite(flip)), "every variant flips within 4 s"
    assert np.all(np.diff(flip) <= 0), "the flip time must fall as the perturbation grows"
    assert flip[0] > 1.5 * flip[-1]
    batch_sizes = set(t["batch_size"].to_pylist())
    assert batch_sizes == {CHUNK}, "variants of one task are stepped as one World"

    for i in (0, 1, 337, 500, 999):
        row = {c: t[c][i].as_py() for c in t.column_names}
        # the sweep's own single-run path (batch=False): every column bit-equal
        single = run_variant(scene_file, {KEY: row[KEY]}, metrics=METRICS)
        assert single["batch_size"] == 1
        for c in t.column_names:
            if c not in ("variant", "wall_time_s", "batch_size"):
                assert single[c] == row[c], (i, c)
        # an independent single run of the variant's scene, as `tumble run` would do it
        data = scene_document()
        data["bodies"][0]["angular_velocity"][0] = row[KEY]
        scene = parse_scene(data, "variant.toml")
        traj = scene.run(progress=False)
        assert checks.state_hash(scene.world) == row["state_hash"]
        assert traj.orientation[-1, 0].tolist() == [row[f"final_orientation:box[{k}]"] for k in range(4)]
        assert traj.angular_velocity[-1, 0].tolist() == [row[f"final_angular_velocity:box[{k}]"] for k in range(3)]
        y = _body_rate_y(traj)
        s = np.sign(y)
        f = int(np.flatnonzero(s[:-1] * s[1:] < 0)[0])
        expected = traj.time[f] - y[f] * (traj.time[f + 1] - traj.time[f]) / (y[f + 1] - y[f])
        assert row["flip_time:box:y"] == pytest.approx(expected, rel=1e-12, abs=1e-12)


# ---------------------------------------------------------------------- 2./3. Dask: LocalCluster, --scheduler, killed worker


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    os.environ["PYTHONPATH"] = env()["PYTHONPATH"]  # the worker processes import tumble from src/
    c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                     silence_logs=logging.ERROR)
    client = Client(c)
    yield c, client
    client.close()
    c.close()


@pytest.mark.slow
def test_local_cluster_and_scheduler_cli_give_the_same_table(reference, scene_file, cluster, tmp_path):
    c, client = cluster
    t_api = run_sweep(scene_file, vary={KEY: SPEC}, metrics=METRICS, out=tmp_path / "api", client=client, chunk_size=CHUNK,
                      progress=False)
    assert same(t_api, reference)
    assert same(pq.read_table(tmp_path / "api" / "results.parquet"), reference)

    args = ["sweep", scene_file, "--vary", f"{KEY}={SPEC}", "--chunk-size", CHUNK, "--out", tmp_path / "cli",
            "--scheduler", c.scheduler_address, "--no-progress"]
    for m in METRICS:
        args += ["--metric", m]
    r = cli(*args)
    assert r.returncode == 0, r.stderr
    assert same(pq.read_table(tmp_path / "cli" / "results.parquet"), reference)


@pytest.mark.slow
def test_killed_worker_loses_no_variant(scene_file, cluster, tmp_path):
    _, client = cluster
    # single runs (no batching) in chunks of 10: long enough (about 3 s) to kill a worker mid-sweep
    vary = {KEY: "linspace(0.001, 0.2, 200)"}
    kw = {"vary": vary, "metrics": METRICS, "chunk_size": 10, "progress": False}
    expected = run_sweep(scene_file, workers=0, **kw)
    client.wait_for_workers(2)
    pids = client.run(os.getpid)
    out = tmp_path / "killed"
    result = {}
    th = threading.Thread(target=lambda: result.setdefault("table", run_sweep(scene_file, out=out, client=client, batch=False, **kw)))
    th.start()
    killed = None
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and killed is None:
        parts = list((out / "parts").glob("chunk-*.parquet")) if (out / "parts").exists() else []
        busy = {w: tasks for w, tasks in client.processing().items() if tasks}
        if len(parts) >= 2 and busy:
            victim = min(busy)
            os.kill(pids[victim], signal.SIGKILL)  # a real kill, mid-task
            killed = victim
        time.sleep(0.02)
    th.join(120)
    assert killed is not None, "the sweep ended before a worker could be killed"
    assert not th.is_alive()
    assert killed not in client.scheduler_info()["workers"], "the worker process really died (its address is gone)"
    table = result["table"]
    assert table.num_rows == 200
    assert set(table["status"].to_pylist()) == {"ok"}, "the killed worker's task was retried"
    assert same(table, expected, drop=("batch_size",))
    client.wait_for_workers(2, timeout=60)  # the nanny restarts the worker for the tests after this one


# ---------------------------------------------------------------------- 4. interrupt and resume


def test_interrupted_sweep_resumes_to_the_same_table(reference, scene_file, tmp_path):
    kw = {"vary": {KEY: SPEC}, "metrics": METRICS, "out": tmp_path, "workers": 0, "chunk_size": CHUNK, "progress": False}
    part = run_sweep(scene_file, stop_after=3, **kw)
    assert part.num_rows == 3 * CHUNK
    assert len(list((tmp_path / "parts").glob("*.parquet"))) == 3
    assert not (tmp_path / "results.parquet").exists()
    before = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "parts").glob("*.parquet")}
    table = run_sweep(scene_file, **kw)
    after = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "parts").glob("*.parquet")}
    assert all(after[n] == before[n] for n in before), "finished chunks are not run again"
    assert same(table, reference)
    assert same(pq.read_table(tmp_path / "results.parquet"), reference)
    # a different sweep in the same folder is refused (exit 2 through the CLI)
    r = cli("sweep", scene_file, "--vary", f"{KEY}=[0.1,0.2]", "--out", tmp_path, "--workers", 0)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "different sweep" in r.stderr


@pytest.mark.slow
def test_cli_sigint_then_resume_gives_the_same_table(reference, tmp_path):
    # the [sweep] table of the scene file holds the sweep; small chunks in this process: about 4 s in all
    scene = write_scene(tmp_path / "scene.toml", {"vary": {KEY: SPEC}, "metrics": METRICS, "chunk_size": 5})
    out = tmp_path / "out"
    args = ["sweep", scene, "--out", out, "--workers", 0, "--no-progress"]
    proc = subprocess.Popen(cli_under_ctrl_c(*args), env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if (out / "parts").exists() and len(list((out / "parts").glob("chunk-*.parquet"))) >= 10:
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    done = len(list((out / "parts").glob("chunk-*.parquet")))
    assert 10 <= done < 200, "interrupted mid-sweep"
    assert "resume" in err and "Traceback" not in err
    r = cli(*args)
    assert r.returncode == 0, r.stderr
    assert same(pq.read_table(out / "results.parquet"), reference, drop=("batch_size",))


# ---------------------------------------------------------------------- 5. batching, bit for bit


def one_body_document() -> dict:
    """A one-body scene with gravity, an initial velocity and drag (a force without cross-variant coupling)."""
    return {
        "simulation": {"duration": 1.0, "dt": 1.0 / 60.0, "frame_rate": 30, "integrator": "rk4"},
        "bodies": [{"name": "box", "shape": {"type": "box", "size": [0.2, 0.6, 1.0]}, "mass": 2.0, "position": [0, 0, 1],
                    "velocity": [1.0, 0.0, 3.0], "angular_velocity": [0.01, 5.0, 0.01], "angular_velocity_frame": "body"}],
        "forces": [{"type": "drag", "linear": 0.1, "angular_linear": 0.01}],
    }


BATCH_VARY = {"bodies.box.angular_velocity[0]": "uniform(-0.5, 0.5)", "bodies.box.mass": "uniform(0.5, 4.0)",
              "bodies.box.velocity[2]": "normal(3.0, 1.0)"}
BATCH_METRICS = ["final_position:box", "final_orientation:box", "final_velocity:box", "final_angular_velocity_body:box",
                 "energy_drift", "flip_time:box:y"]


@pytest.mark.slow
def test_batched_10000_variants_match_separate_runs_bit_for_bit():
    doc = one_body_document()
    table = run_sweep(doc, vary=BATCH_VARY, samples=10_000, seed=7, metrics=BATCH_METRICS, workers=0, chunk_size=10_000,
                      progress=False)
    assert table.num_rows == 10_000
    assert set(table["status"].to_pylist()) == {"ok"}
    assert set(table["batch_size"].to_pylist()) == {10_000}, "all 10 000 variants in one World"
    cols = {c: table[c].to_pylist() for c in table.column_names}

    # (a) 200 variants, chosen at random, each through a full single run: every column bit-equal
    rng = np.random.default_rng(1)
    for i in sorted(rng.choice(10_000, 200, replace=False)):
        values = {k: cols[k][i] for k in BATCH_VARY}
        single = run_variant(doc, values, metrics=BATCH_METRICS)
        for c in table.column_names:
            if c not in ("variant", "wall_time_s", "batch_size"):
                assert single[c] == cols[c][i] or (single[c] != single[c] and cols[c][i] != cols[c][i]), (i, c)

    # (b) all 10 000 through a cheaper independent path: each variant's own World, stepped to the end
    # in one call (Simulator.step: no frames recorded), its state hash equal to the batch's
    steps = round(doc["simulation"]["duration"] / doc["simulation"]["dt"])
    for i in range(10_000):
        d = copy.deepcopy(doc)
        d["bodies"][0]["angular_velocity"][0] = cols["bodies.box.angular_velocity[0]"][i]
        d["bodies"][0]["mass"] = cols["bodies.box.mass"][i]
        d["bodies"][0]["velocity"][2] = cols["bodies.box.velocity[2]"][i]
        scene = parse_scene(d)
        scene.simulator().step(steps)
        assert checks.state_hash(scene.world) == cols["state_hash"][i], i


def test_a_fluid_scene_batches_bit_for_bit():
    """A box in MuJoCo's fluid (``type = "fluid"``, air-like: its density and the box's mass varied;
    water's density with RK4 at 1/60 s is stiff past the explicit step's reach, as MuJoCo says of its
    own): the 12 variants run in one World, each bit for bit its own single run (every metric and
    the state hash)."""
    doc = one_body_document()
    doc["forces"] = [{"type": "fluid", "density": 1.2, "viscosity": 0.02, "wind": [0.3, 0.0, 0.0]}]
    vary = {"bodies.box.mass": "uniform(0.5, 4.0)", "forces[0].density": "uniform(0.5, 2.0)"}
    table = run_sweep(doc, vary=vary, samples=12, seed=3, metrics=BATCH_METRICS, workers=0, progress=False)
    assert set(table["status"].to_pylist()) == {"ok"} and set(table["batch_size"].to_pylist()) == {12}
    cols = {c: table[c].to_pylist() for c in table.column_names}
    for i in range(12):
        single = run_variant(doc, {k: cols[k][i] for k in vary}, metrics=BATCH_METRICS)
        for c in table.column_names:
            if c not in ("variant", "wall_time_s", "batch_size"):
                assert single[c] == cols[c][i] or (single[c] != single[c] and cols[c][i] != cols[c][i]), (i, c)


def test_failing_variants_are_recorded_and_do_not_stop_the_sweep(tmp_path):
    doc = one_body_document()
    doc["simulation"]["max_energy_growth"] = 10.0
    # mass -1: InputError of that variant; a huge constant force pumps energy past its bound: SimulationError
    doc["forces"].append({"type": "constant", "body": "box", "force": [0.0, 0.0, 0.0]})
    table = run_sweep(doc, vary={"bodies.box.mass": [1.0, -1.0, 2.0], "forces[1].force[0]": [0.0, 1e6]}, metrics=["energy_drift"],
                      workers=0, out=tmp_path, save_trajectories=True, progress=False)
    rows = table.to_pylist()
    assert len(rows) == 6
    by = {(r["bodies.box.mass"], r["forces[1].force[0]"]): r for r in rows}
    assert by[(1.0, 0.0)]["status"] == "ok" and by[(2.0, 0.0)]["status"] == "ok"
    for f in (0.0, 1e6):
        r = by[(-1.0, f)]
        assert r["status"] == "failed" and r["error_kind"] == "input" and "bodies[0].mass" in r["error"]
    for m in (1.0, 2.0):
        r = by[(m, 1e6)]
        assert r["status"] == "failed" and r["error_kind"] == "simulation" and "energy" in r["error"], r
        assert r["state_hash"] is None and np.isnan(r["energy_drift"])
    # the ok variants' trajectories are kept, loadable, and equal to their single runs
    ok = [r["variant"] for r in rows if r["status"] == "ok"]
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == [f"variant-{i:07d}.npz" for i in ok]
    traj = tb.load_trajectory(tmp_path / "runs" / f"variant-{ok[0]:07d}.npz")
    d = one_body_document()
    d["bodies"][0]["mass"] = 1.0
    d["simulation"]["max_energy_growth"] = 10.0
    d["forces"].append({"type": "constant", "body": "box", "force": [0.0, 0.0, 0.0]})
    ref = parse_scene(d).run(progress=False)
    for k in ("position", "orientation", "velocity", "angular_velocity", "linear_momentum", "angular_momentum", "time"):
        assert np.array_equal(getattr(traj, k), getattr(ref, k)), k


def test_saved_trajectories_of_a_batch_equal_single_runs(tmp_path):
    doc = one_body_document()
    vals = [0.5, 1.0, 3.0]
    t = run_sweep(doc, vary={"bodies.box.mass": vals}, metrics=["energy_drift"], workers=0, out=tmp_path, save_trajectories=True,
                  progress=False)
    assert t["batch_size"].to_pylist() == [3, 3, 3]
    for i, m in enumerate(vals):
        traj = tb.load_trajectory(tmp_path / "runs" / f"variant-{i:07d}.npz")
        d = one_body_document()
        d["bodies"][0]["mass"] = m
        ref = parse_scene(d).run(progress=False)
        for k in ("time", "position", "orientation", "velocity", "angular_velocity", "linear_momentum", "angular_momentum"):
            assert np.array_equal(getattr(traj, k), getattr(ref, k)), k
        assert list(traj.names) == ["box"]
        np.testing.assert_allclose(traj.kinetic_energy, ref.kinetic_energy, rtol=1e-14)
        np.testing.assert_allclose(traj.potential_energy, ref.potential_energy, rtol=1e-14)


def test_a_sweep_over_gravity_scales_batches_and_equals_single_runs(tmp_path):
    """``gravity_scale`` varied (0.3, 1, -0.5): the three variants run in one World (each body's row
    (s - 1) m g its own) and each saved trajectory is its single run's bit for bit, its potential
    energy s m g h to 1e-14 (summed apart from the engine's); the energy_drift metric equals the
    single run's, and both the drift of the engine's own energy (1e-9: the metrics' potential
    takes each variant's scale too; with the first variant's, or none, the others' read wrong)."""
    doc = one_body_document()
    scales = [0.3, 1.0, -0.5]
    t = run_sweep(doc, vary={"bodies.box.gravity_scale": scales}, metrics=["energy_drift"], workers=0, out=tmp_path,
                  save_trajectories=True, progress=False)
    assert t["batch_size"].to_pylist() == [3, 3, 3]
    for i, s in enumerate(scales):
        traj = tb.load_trajectory(tmp_path / "runs" / f"variant-{i:07d}.npz")
        d = one_body_document()
        d["bodies"][0]["gravity_scale"] = s
        ref = parse_scene(d).run(progress=False)
        for k in ("position", "velocity", "angular_momentum"):
            assert np.array_equal(getattr(traj, k), getattr(ref, k)), k
        np.testing.assert_allclose(traj.potential_energy, ref.potential_energy, rtol=1e-14)
        single = run_variant(doc, {"bodies.box.gravity_scale": s}, metrics=["energy_drift"])
        assert t["energy_drift"].to_pylist()[i] == single["energy_drift"]
        e = ref.kinetic_energy + ref.potential_energy  # the metric's energy is the engine's
        assert single["energy_drift"] == pytest.approx((e[-1] - e[0]) / abs(e[0]), rel=1e-9)


def test_random_design_is_seeded_and_reproducible():
    doc = one_body_document()
    kw = {"vary": BATCH_VARY, "metrics": ["energy_drift"], "workers": 0, "progress": False}
    a = run_sweep(doc, samples=50, seed=3, **kw)
    b = run_sweep(doc, samples=50, seed=3, **kw)
    c = run_sweep(doc, samples=50, seed=4, **kw)
    assert same(a, b)
    assert a["bodies.box.mass"].to_pylist() != c["bodies.box.mass"].to_pylist()
    masses = np.array(a["bodies.box.mass"].to_pylist())
    assert masses.min() >= 0.5 and masses.max() < 4.0


def test_grid_of_two_keys_and_specs():
    doc = one_body_document()
    t = run_sweep(doc, vary=["bodies.box.mass=[1, 2]", "simulation.integrator=[rk4, splitting]", "forces[0].linear=range(0, 0.3, 0.1)"],
                  metrics=["final_position:box"], workers=0, progress=False)
    assert t.num_rows == 2 * 2 * 3
    assert t["bodies.box.mass"].to_pylist() == [1] * 6 + [2] * 6  # the first key varies slowest
    assert t["simulation.integrator"].to_pylist()[:6] == ["rk4"] * 3 + ["splitting"] * 3
    assert t["forces[0].linear"].to_pylist()[:3] == [0.0, 0.1, 0.2]
    assert set(t["status"].to_pylist()) == {"ok"}
    # variants that differ in the integrator are not batched together
    assert set(t["batch_size"].to_pylist()) == {6}


# ---------------------------------------------------------------------- bad input


BAD = [
    (["--vary", "bodies.nobody.mass=[1,2]"], "no body named 'nobody'"),
    (["--vary", "bodies.box.colour=[1,2]"], "not in the scene"),
    (["--vary", "simulation.nope=[1]"], "not in the scene"),
    (["--vary", "forces[3].linear=[1]"], "forces"),
    (["--vary", "bodies.box.angular_velocity[7]=[1]"], "no [7]"),
    (["--vary", "bodies.box.angular_velocity=[1]"], "names a list"),
    (["--vary", "bodies.box.mass=linspace(1,2)"], "linspace takes 3 arguments"),
    (["--vary", "bodies.box.mass=[1,,2]"], "empty list item"),
    (["--vary", "bodies.box.mass=uniform(2,1)"], "a < b"),
    (["--vary", "bodies.box.mass=range(1,2,-1)"], "the step must go"),
    (["--vary", "bodies.box.mass"], "KEY=SPEC"),
    (["--vary", "bodies.box.mass=[1,2]", "--samples", "5"], "needs at least one distribution"),
    (["--vary", "bodies.box.mass=normal(2,0.1)"], "needs --samples"),
    (["--vary", "bodies.box.mass=[1,2]", "--seed", "3"], "--seed only matters"),
    (["--vary", "bodies.box.mass=[1,2]", "--metric", "flip_time:box:q"], "axis"),
    (["--vary", "bodies.box.mass=[1,2]", "--metric", "final_position:ghost"], "unknown body"),
    (["--vary", "bodies.box.mass=[1,2]", "--metric", "speed"], "unknown metric"),
    (["--vary", "bodies.box.mass=[1,2]", "--scheduler", "tcp://127.0.0.1:9"], "cannot connect"),
    ([], "nothing to vary"),
]


def _api_kwargs(args):
    kw = {"vary": [], "metrics": []}
    it = iter(args)
    for a in it:
        v = next(it)
        if a == "--vary":
            kw["vary"].append(v)
        elif a == "--metric":
            kw["metrics"].append(v)
        else:
            kw[a[2:]] = int(v) if v.isdigit() else v
    kw["metrics"] = kw["metrics"] or None
    return kw


@pytest.mark.parametrize("args, words", BAD)
def test_bad_input_raises_one_line_input_error(scene_file, tmp_path, args, words):
    kw = _api_kwargs(args)
    if "scheduler" not in kw:
        kw["workers"] = 0
    with pytest.raises(tb.InputError) as info:
        run_sweep(scene_file, out=tmp_path / "o", progress=False, **kw)
    line = str(info.value)
    assert "\n" not in line and words in line, line
    assert not (tmp_path / "o" / "parts").exists()


@pytest.mark.parametrize("args, words", [BAD[0], BAD[6], BAD[11], BAD[15], BAD[17]])
def test_bad_input_exits_2_with_one_line(scene_file, tmp_path, args, words):
    extra = [] if "--scheduler" in args else ["--workers", "0"]
    r = cli("sweep", scene_file, "--out", tmp_path / "o", *extra, *args, timeout=60)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("tumble: error:") and words in lines[0], lines[0]
    assert not (tmp_path / "o" / "parts").exists()


def test_bad_sweep_table_and_bad_scene(tmp_path):
    bad = write_scene(tmp_path / "bad.toml", {"vary": {KEY: SPEC}, "colour": "red"})
    r = cli("sweep", bad, "--out", tmp_path / "o", "--workers", 0)
    assert r.returncode == 2 and "sweep.colour: unknown key" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = cli("sweep", tmp_path / "missing.toml", "--vary", f"{KEY}=[1]", "--out", tmp_path / "o")
    assert r.returncode == 2 and "file not found" in r.stderr


def test_sweep_table_accepted_and_stripped(tmp_path):
    """A scene file with a [sweep] table still runs as a sweep; the table is not passed to the scene loader."""
    scene = write_scene(tmp_path / "s.toml", {"vary": {KEY: "[0.01, 0.02]"}, "metrics": ["flip_time:box:y"]})
    r = cli("sweep", scene, "--out", tmp_path / "o", "--workers", 0, "--no-progress")
    assert r.returncode == 0, r.stderr
    t = pq.read_table(tmp_path / "o" / "results.parquet")
    assert t.num_rows == 2 and "flip_time:box:y" in t.column_names


def test_scenes_with_contact_or_coupled_joints_are_not_batched():
    """Variants merged into one World must not touch each other and must keep their joints' bits:
    a scene that can collide runs alone (batch_key None); joints batch (each variant's swept in its
    own order) unless the tree method has a limit (its extra sweeps stop on a test over every
    joint: it would couple the variants). Batched joints are checked bit for bit against single
    runs in tests/test_urdf.py."""
    from tumble.scene import parse_scene
    from tumble.sweep.batch import batch_key

    ball = {"name": "b", "shape": {"type": "sphere", "radius": 0.1}, "mass": 1.0}
    ground = {"name": "g", "shape": {"type": "plane"}, "fixed": True}
    assert batch_key(parse_scene({"bodies": [ball]})) is not None
    assert batch_key(parse_scene({"bodies": [ground, ball]})) is None
    assert batch_key(parse_scene({"simulation": {"collisions": False}, "bodies": [ground, ball]})) is not None
    jointed = {"simulation": {"collisions": False}, "bodies": [ball],
               "joints": [{"type": "hinge", "body_a": "b", "anchor": [0, 0, 1], "axis": [0, 1, 0], "lower": -1.0}]}
    assert batch_key(parse_scene(jointed)) is not None
    assert batch_key(parse_scene({**jointed, "joint_solver": {"method": "tree"}})) is None
    del jointed["joints"][0]["lower"]
    assert batch_key(parse_scene({**jointed, "joint_solver": {"method": "tree"}})) is not None


def test_sensor_metrics_count_the_parcels_the_belt_brings():
    """``final_sensor_visitors`` and ``max_sensor_visitors`` of examples/conveyor.toml's bin,
    for three speeds of the belt (the x of its surface velocity): in 6 s the belt at 0.8 m/s
    brings 3 parcels (their begins at 4.63, 5.18, 5.72 s, tests/test_examples_contact.py), at
    1.6 m/s all 6, and a still belt none; a body that is not a sensor is refused in one line."""
    data = tomllib.loads((ROOT / "examples" / "conveyor.toml").read_text())
    data["simulation"]["duration"] = 6.0
    metrics = ["final_sensor_visitors:bin_sensor", "max_sensor_visitors:bin_sensor"]
    counts = {}
    for speed in (0.0, 0.8, 1.6):
        row = run_variant(copy.deepcopy(data), {"bodies.belt.surface_velocity[0]": speed}, metrics=metrics)
        assert row["status"] == "ok", row
        counts[speed] = (row["final_sensor_visitors:bin_sensor"], row["max_sensor_visitors:bin_sensor"])
    assert counts == {0.0: (0.0, 0.0), 0.8: (3.0, 3.0), 1.6: (6.0, 6.0)}
    with pytest.raises(tb.InputError, match="'belt' is not a sensor"):
        run_variant(copy.deepcopy(data), {"bodies.belt.surface_velocity[0]": 1.0}, metrics=["final_sensor_visitors:belt"])
