"""Shared by the bad-input tests: ``refused(call, key)``, the one-line ``InputError`` a call must raise."""

import pytest

from tumble.errors import InputError


def refused(call, key, problem=None) -> InputError:
    """``call()`` raises an InputError keyed ``key`` (and nothing else), one line; ``problem``, if
    given, is part of its problem text."""
    with pytest.raises(Exception) as info:
        call()
    err = info.value
    assert type(err) is InputError, f"{type(err).__name__}: {err}"
    assert err.key == key, str(err)
    assert "\n" not in str(err)
    if problem is not None:
        assert problem in err.problem, str(err)
    return err
