"""Recompute tests/determinism/golden.json: ``PYTHONPATH=src python -m tests.determinism.update_golden``.

Run it only when a change is meant to change the bits of a run (e.g. a kernel
rewrite), say so in the commit message, and check the physics tests still pass. The hashes are
those of OpenBLAS's Haswell kernels (tests/conftest.py pins them).
"""

import json

from ..conftest import PINNED_BLAS_CORE  # first: it pins OpenBLAS's kernels before NumPy loads
from .scenes import GOLDEN, blas_core, final_hash, scene_paths


def main():
    if blas_core() != PINNED_BLAS_CORE:
        raise SystemExit(f"NumPy's OpenBLAS runs its {blas_core()} kernels, the hashes are {PINNED_BLAS_CORE}'s "
                         "(tests/conftest.py): run this on an AVX2 machine, NumPy not yet imported")
    golden = {name: final_hash(path) for name, path in scene_paths().items()}
    GOLDEN.write_text(json.dumps(golden, indent=2, sort_keys=True) + "\n")
    for name, h in golden.items():
        print(f"{name}: {h}")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
