"""Headless Chromium for the browser tests (the viewers, the exported web page): Debian's
Chromium from ``.ci/setup.d/chromium.sh`` driven by the Python playwright package through
``executable_path`` (playwright's own browser download is never used). Without /usr/bin/chromium
the browser tests fail when ``CI`` is set and are skipped otherwise."""

from __future__ import annotations

import os

import pytest

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-quic",
]
BENIGN_CONSOLE_ERRORS = (
    "favicon.ico",
    "GL Driver Message",
    "GPU stall due to ReadPixels",
)


def browser_session():
    """Yield a launched headless Chromium (a fixture's body), closed after; skip or fail without one."""
    if not os.path.exists(CHROMIUM):
        message = f"{CHROMIUM} not found: run .ci/setup.d/chromium.sh"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        try:
            yield b
        finally:
            b.close()
