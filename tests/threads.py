"""Running a piece of a test on a given number of Numba threads."""

import contextlib

import numba


@contextlib.contextmanager
def numba_threads(n: int):
    """Numba's parallel kernels use ``n`` threads inside the block; the count before after it."""
    before = numba.get_num_threads()
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(before)
