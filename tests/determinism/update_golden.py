"""Recompute tests/determinism/golden.json: ``PYTHONPATH=src python -m tests.determinism.update_golden``.

Run it only when a change is meant to change the bits of a run (e.g. a kernel
rewrite), say so in the commit message, and check the physics tests still pass.
"""

import json

from .scenes import GOLDEN, final_hash, scene_paths


def main():
    golden = {name: final_hash(path) for name, path in scene_paths().items()}
    GOLDEN.write_text(json.dumps(golden, indent=2, sort_keys=True) + "\n")
    for name, h in golden.items():
        print(f"{name}: {h}")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
