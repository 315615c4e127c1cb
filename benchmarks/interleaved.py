"""A/B runs of a benchmark at two revisions, interleaved in one run, each a fresh process (the
benchmarks ``step_overhead.py``, ``env_ab.py``, ``ragdolls_tree.py``): each revision a checkout
(``git worktree add --detach DIR REV``), its ``src`` on the path."""
import json
import os
import subprocess
import sys

# passed on to the runs when set: a private Numba cache, the thread count, OpenMP's wait policy
PASSED_ON = ("NUMBA_CACHE_DIR", "NUMBA_NUM_THREADS", "OMP_WAIT_POLICY")


def take_rounds(args: list, default: int) -> int:
    """The value of ``--rounds N`` in ``args`` (removed from it), else ``default``."""
    if "--rounds" in args:
        i = args.index("--rounds")
        rounds = int(args[i + 1])
        del args[i:i + 2]
        return rounds
    return default


def interleaved(code: str, old: str, new: str, cases: list, rounds: int) -> dict:
    """Run ``python -c code *case`` for each case (a tuple of its arguments), at ``old`` then
    ``new``, ``rounds`` times over; returns {(case, "old" or "new"): [the JSON of its last output
    line, one a round]}. A failed run stops all with its last line of error."""
    results = {}
    for _ in range(rounds):
        for case in cases:
            for rev, folder in (("old", old), ("new", new)):
                env = {"PYTHONPATH": "src", "PATH": "/usr/bin:/bin"}
                env.update({k: os.environ[k] for k in PASSED_ON if k in os.environ})
                out = subprocess.run([sys.executable, "-c", code, *map(str, case)], cwd=folder,
                                     env=env, capture_output=True, text=True)
                if out.returncode:
                    raise SystemExit(f"{case} at {folder}: {out.stderr.strip().splitlines()[-1]}")
                results.setdefault((case, rev), []).append(json.loads(out.stdout.strip().splitlines()[-1]))
    return results
