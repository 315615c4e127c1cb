"""What the benchmark scripts share: the machine line heading a results table, and writing the table."""

from __future__ import annotations

import os
import platform
import subprocess


def machine_line(note: str = "") -> str:
    """``machine: x86_64, 2 cores, Python 3.11.7, tumble git abc1234`` and ``note`` after a semicolon."""
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    line = f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {git}"
    return f"{line}; {note}" if note else line


def emit(lines: list[str], out: str | None):
    """Print the table's lines and, given ``out``, write them to that file."""
    text = "\n".join(lines)
    print(text)
    if out:
        with open(out, "w") as f:
            f.write(text + "\n")
