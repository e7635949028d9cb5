"""limits.check: one table of ranges, one message naming the quantity, the value and the range."""

from __future__ import annotations

import math

import pytest

from ema_phm.errors import ConfigError, EmaPhmError
from ema_phm.limits import LIMITS, Limit, check


def test_every_limit_is_a_sane_closed_range():
    for name, lim in LIMITS.items():
        assert math.isfinite(lim.low) and math.isfinite(lim.high) and lim.low <= lim.high, name
        if lim.integer:
            assert float(lim.low).is_integer() and float(lim.high).is_integer(), name


@pytest.mark.parametrize(
    "value", [-1, 2**31, 2**32, 1.5, math.inf, math.nan, "abc", None, True, 10**400]
)
def test_seed_outside_its_range_or_not_an_integer_is_refused_with_the_range(value):
    with pytest.raises(ConfigError) as info:
        check("seed", value)
    msg = str(info.value)
    assert msg.startswith("seed must be an integer in [0, ") and repr(value)[:20] in msg
    assert isinstance(info.value, EmaPhmError)


def test_values_inside_are_returned_as_numbers():
    assert check("seed", 0) == 0 and isinstance(check("seed", 7.0), int)
    assert check("seed", "12") == 12
    assert check("duration", "2") == 2.0
    assert check("max_evaluations", 200_000) == 200_000
    assert check("noise_current", 0.0) == 0.0


def test_label_and_an_explicit_limit():
    with pytest.raises(ConfigError, match=r"^f1 must be a number in \[0, 1000\] Hz, got 5000"):
        check("frequency", 5000, label="f1")
    with pytest.raises(ConfigError, match=r"^x must be a number in \[1, 2\] m"):
        check("ignored", 3, limit=Limit(1, 2, "m"), label="x")
