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


def pytest_configure(config):
    # here, not in pyproject.toml: resolving the class imports Numba and NumPy (module docstring)
    config.addinivalue_line("filterwarnings", "ignore::numba.core.errors.NumbaPerformanceWarning")
