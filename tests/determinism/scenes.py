"""The scenes whose final ``state_hash`` is pinned in golden.json, and how each is run."""

from pathlib import Path

from tumble.checks import state_hash
from tumble.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).with_name("golden.json")


def scene_paths() -> dict:
    """{name: path}: examples/*.toml and src/tumble/scenes/demo.toml."""
    paths = {p.stem: p for p in sorted((ROOT / "examples").glob("*.toml"))}
    paths["demo"] = ROOT / "src" / "tumble" / "scenes" / "demo.toml"
    return paths


def final_hash(path) -> str:
    """Run the scene for its full duration on the compiled path and hash the final state."""
    scene = load_scene(path)
    scene.run(progress=False)
    return state_hash(scene.world)
