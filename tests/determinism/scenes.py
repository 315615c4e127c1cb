"""The scenes whose final ``state_hash`` is pinned in golden.json, and how each is run."""

from pathlib import Path

from tumble.checks import state_hash
from tumble.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).with_name("golden.json")


# Examples with more bodies than this are left out: each scene here runs three times in CI
# (golden hash, two CLI runs, the validated path); the big contact scenes (pile, pyramid) have
# their own determinism checks at a smaller size (tests/test_contact_records.py).
MAX_BODIES = 100


def scene_paths() -> dict:
    """{name: path}: examples/*.toml with at most MAX_BODIES bodies, and src/tumble/scenes/demo.toml."""
    import tomllib

    paths = {}
    for p in sorted((ROOT / "examples").glob("*.toml")):
        if len(tomllib.loads(p.read_text()).get("bodies", [])) <= MAX_BODIES:
            paths[p.stem] = p
    paths["demo"] = ROOT / "src" / "tumble" / "scenes" / "demo.toml"
    return paths


def final_hash(path) -> str:
    """Run the scene for its full duration on the compiled path and hash the final state."""
    scene = load_scene(path)
    scene.run(progress=False)
    return state_hash(scene.world)


def blas_core() -> str | None:
    """The kernel set NumPy's OpenBLAS runs (``"Haswell"``, ``"SkylakeX"``...; tests/conftest.py
    pins it), or None when NumPy's BLAS is not the OpenBLAS of its wheel."""
    import ctypes
    import glob

    import numpy as np

    libs = Path(np.__file__).resolve().parent.parent / "numpy.libs"
    for lib in sorted(glob.glob(str(libs / "*openblas*"))):
        handle = ctypes.CDLL(lib)
        for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename64_",
                     "openblas_get_corename"):
            fn = getattr(handle, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                return fn().decode()
    return None
