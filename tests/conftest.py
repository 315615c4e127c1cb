"""Suite-wide set-up that must happen before NumPy is imported.

OpenBLAS picks its kernels by the CPU (``DYNAMIC_ARCH``): on an AVX-512 machine NumPy's
matrix products, ``norm`` and ``linalg`` run its SkylakeX or Cooperlake kernels, on others its
Haswell ones, and those round differently in the last bit (a 3x3 QR, a ``R @ x``: measured,
2026-12-04). tumble's set-up code (scene poses, keyframed paths, fractured cells, the tests'
random rotations) goes through them, so the golden state hashes (``tests/determinism``) and the
random cases of the tests would depend on which machine runs the suite: CI once failed on a
machine whose environment chose Haswell against hashes recorded with SkylakeX kernels. The
suite pins one kernel set, Haswell's (AVX2 and FMA: every x86-64-v3 CPU; faster ones run it
too), so that its bits are those of any such machine (subprocesses of the tests inherit it).
``tests/determinism`` checks that the pin took (``blas_core``).
"""

import os
import sys


def _cpu_has(*flags: str) -> bool:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("flags"):
                    have = set(line.split(":", 1)[1].split())
                    return all(f in have for f in flags)
    except OSError:
        pass
    return False


PINNED_BLAS_CORE = "Haswell"
if "numpy" not in sys.modules and _cpu_has("avx2", "fma"):
    os.environ["OPENBLAS_CORETYPE"] = PINNED_BLAS_CORE

# The suite runs two worker processes (pytest-xdist) on a 2-core machine, each with Numba's two
# threads: GNU OpenMP's waiting threads spin, and a parallel region whose other thread was
# descheduled waited out a scheduler slice. Passive waiting, before OpenMP is loaded (the first
# parallel kernel), in this process and the tests' subprocesses. Measured (session 43, the 1000-box
# pile at Box3D's step, 2 threads): beside two busy processes, 0.41 -> 1.41 times real time; idle,
# 2.70 -> 2.26 (docs/benchmarks.md, "Threads on shared cores"). Results do not depend on it.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def pytest_configure(config):
    # here, not in pyproject.toml: resolving the class imports Numba and NumPy (module docstring)
    config.addinivalue_line("filterwarnings", "ignore::numba.core.errors.NumbaPerformanceWarning")
