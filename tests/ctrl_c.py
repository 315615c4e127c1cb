"""The command line as a terminal's Ctrl-C would reach it, for tests that send SIGINT to a child ``tumble``.

A process started with SIGINT ignored (a non-interactive shell's background job, ``nohup``, a CI runner that
starts jobs so) passes that on to its children, and Python then installs no KeyboardInterrupt handler: the
child ignores the test's SIGINT and runs to its end (exit 0), which is the convention for such programs, not
the terminal's Ctrl-C the test means. So the child sets Python's handler itself before it starts the CLI.
"""

import sys

_START = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
          "from tumble.cli import main; sys.exit(main(sys.argv[1:]))")


def cli_under_ctrl_c(*args) -> list[str]:
    """argv of ``tumble ARGS...`` in a child Python whose SIGINT raises KeyboardInterrupt, whatever it inherited."""
    return [sys.executable, "-c", _START, *map(str, args)]
