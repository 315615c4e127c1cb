"""Sweep specs and [sweep] tables: a bad value is one InputError line naming where it came from
(an input audit, session 42: its cases A3, B2, H6)."""

import subprocess
import sys

import pytest

from tumble.sweep.runner import SweepDefinition
from tumble.sweep.spec import parse_spec

from .refusals import refused

SCENE = """\
[simulation]
duration = 0.125
[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 1.0
"""
KEY = "bodies.ball.mass"
BIG = "1" + "0" * 5000  # over Python's 4300-digit limit on reading an integer


def scene(tmp_path, table: str = "", name="s.toml"):
    path = tmp_path / name
    path.write_text(SCENE + table)
    return path


@pytest.mark.parametrize("spec", [BIG, f"[1, {BIG}]", "-" + BIG, "[99999999999999999999]", 10**30, [10**30], [1, -10**5000]])
def test_a_whole_number_too_large_is_a_bad_spec(spec):  # A3, B2
    err = refused(lambda: parse_spec(KEY, spec), f"--vary {KEY}", "is beyond 2^63 - 1")
    assert len(str(err)) < 400


def test_whole_numbers_in_range_and_large_floats_are_taken():
    assert parse_spec(KEY, "[9223372036854775807, 2]").values == (2**63 - 1, 2)
    assert parse_spec(KEY, "1e30").values == (1e30,)
    assert parse_spec(KEY, [1e30, 3]).values == (1e30, 3)


def test_a_vary_option_with_a_huge_integer_is_one_line(tmp_path):  # A3
    refused(lambda: SweepDefinition(scene(tmp_path), vary=[f"{KEY}={BIG}"]), f"--vary {KEY}", "5001 digits")


def test_a_sweep_table_with_a_huge_integer_in_the_file_is_one_line(tmp_path):
    path = scene(tmp_path, f'[sweep]\nvary = {{ "{KEY}" = [{BIG}] }}\n')
    err = refused(lambda: SweepDefinition(path), None)
    assert str(err) == (f"{path}: invalid TOML: an integer of more than 4300 digits "
                        "(write a number that large as a float, e.g. 1e5000)")


@pytest.mark.parametrize("table, key, problem", [  # H6
    (f'vary = {{ "{KEY}" = [] }}', f'sweep.vary."{KEY}"', "bad spec []: an empty list"),
    (f'vary = {{ "{KEY}" = [1000000000000000000000000000000] }}', f'sweep.vary."{KEY}"', "is beyond 2^63 - 1"),  # B2
    ('vary = { "bodies.nobody.mass" = [1, 2] }', 'sweep.vary."bodies.nobody.mass"', "no body named 'nobody'"),
    (f'vary = {{ "{KEY}" = "uniform(0, 1)" }}\nsamples = -1', "sweep.samples", "must be a whole number >= 1, got -1"),
    (f'vary = {{ "{KEY}" = "uniform(0, 1)" }}\nsamples = 4\nseed = "x"', "sweep.seed", "got 'x'"),
    (f'vary = {{ "{KEY}" = [1, 2] }}\nseed = 3', "sweep.seed", "only matters with --samples"),
    (f'vary = {{ "{KEY}" = [1, 2] }}\nmetrics = [5]', "sweep.metrics", None),
    (f'vary = {{ "{KEY}" = [1, 2] }}\nmetrics = ["nonsense"]', "sweep.metrics", "unknown metric"),
    (f'vary = {{ "{KEY}" = [1, 2] }}\nchunk_size = 0', "sweep.chunk_size", "must be a whole number >= 1"),
])
def test_a_bad_sweep_table_value_names_the_file_and_its_key(tmp_path, table, key, problem):
    path = scene(tmp_path, "[sweep]\n" + table + "\n")
    err = refused(lambda: SweepDefinition(path), key, problem)
    assert err.file == str(path)


def test_the_options_keep_their_own_names(tmp_path):
    path = scene(tmp_path)
    refused(lambda: SweepDefinition(path, vary=[f"{KEY}=[]"]), f"--vary {KEY}", "an empty list")
    refused(lambda: SweepDefinition(path, vary=[f"{KEY}=uniform(0,1)"], samples=-1), "--samples")
    refused(lambda: SweepDefinition(path, vary=[f"{KEY}=uniform(0,1)"], samples=2, seed="x"), "--seed")
    refused(lambda: SweepDefinition(path, vary=[f"{KEY}=[1]"], metrics=["nonsense"]), "--metric")
    # an option given for a key the table also varies replaces the table's (bad) spec
    path = scene(tmp_path, f'[sweep]\nvary = {{ "{KEY}" = [] }}\n', name="t.toml")
    assert SweepDefinition(path, vary=[f"{KEY}=[1, 2]"]).count == 2


def test_the_cli_says_one_line_for_a_bad_sweep_table(tmp_path):  # H6, through the command
    path = scene(tmp_path, f'[sweep]\nvary = {{ "{KEY}" = [] }}\n')
    r = subprocess.run([sys.executable, "-m", "tumble", "sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert r.stderr.splitlines() == [f'tumble: error: {path}: sweep.vary."{KEY}": bad spec []: an empty list']


def test_too_many_samples_in_the_table_names_the_table(tmp_path):
    path = scene(tmp_path, f'[sweep]\nvary = {{ "{KEY}" = "uniform(0, 1)" }}\nsamples = 1000000000000000000000000000000\n')
    err = refused(lambda: SweepDefinition(path), "sweep.samples", "must be at most")
    assert "integer of 31 digits" in err.problem and err.file == str(path)


@pytest.mark.parametrize("table, key, problem", [
    (f'vary = {{ "{KEY}" = "uniform(1, 2)" }}', f'sweep.vary."{KEY}"', "is a distribution: random sampling needs"),
    (f'vary = {{ "{KEY}" = "linspace(1, 2, 20000)", "simulation.duration" = "linspace(0.1, 0.2, 20000)" }}',
     "sweep.vary", "variants (more than"),
])
def test_the_designs_errors_name_the_table_when_the_values_are_its(tmp_path, table, key, problem):
    """Errors of the design itself (a distribution with no samples, a grid too large) named the
    command-line options (``--vary``) when the values came from the file's ``[sweep]`` table: now its
    key and the file; a ``--vary`` option's stay its own."""
    path = scene(tmp_path, "[sweep]\n" + table + "\n")
    err = refused(lambda: SweepDefinition(path), key, problem)
    assert err.file == str(path)
    refused(lambda: SweepDefinition(scene(tmp_path, name="o.toml"), vary=[f"{KEY}=uniform(1,2)"]), f"--vary {KEY}")
