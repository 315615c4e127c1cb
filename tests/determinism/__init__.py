"""Golden state hashes: every example scene and the built-in demo, run in full, must end in the recorded state."""
