"""``python -m tumble ...``: the ``tumble`` command (``tumble.cli.main``), for environments where
the console script is not on PATH (a venv not activated, a notebook's ``!python -m tumble``)."""

import sys

from .cli import main

sys.exit(main())
