"""Fuzz: prior arguments of any value and type build a usable prior or raise one ValueError /
TypeError line naming the prior (config entries: tests/config/test_fuzz_config.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from torchshm import Gamma, Normal, Uniform

FUZZ = settings(max_examples=80, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])

VALUE = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5), st.sampled_from([0.0, -0.0, 1e-300, 1e300]),
    st.text(max_size=3), st.none(), st.booleans(), st.lists(st.floats(-10, 10), max_size=3),
)
PAIR = st.one_of(st.none(), st.tuples(VALUE, VALUE), st.lists(st.floats(allow_nan=True), max_size=3), VALUE)
FAMILY = st.sampled_from([Uniform, Gamma, Normal])


def _usable(prior) -> None:
    lo, hi = prior.hard_bounds
    p_lo, p_hi = prior.plausible_bounds
    assert lo < hi and lo <= p_lo < p_hi <= hi and math.isfinite(p_lo) and math.isfinite(p_hi)
    draws = prior.sample(50, np.random.default_rng(0))
    assert np.all((draws >= lo) & (draws <= hi)) and np.isfinite(draws).all()
    assert np.isfinite(prior.log_prob(draws)).all()


@FUZZ
@given(family=FAMILY, first=VALUE, second=VALUE, bounds=PAIR, plausible=PAIR)
def test_fuzzed_python_priors(family, first, second, bounds, plausible) -> None:
    kwargs = {"plausible": plausible}
    if family is not Uniform:
        kwargs["bounds"] = bounds
    try:
        prior = family(first, second, **kwargs)
    except (ValueError, TypeError) as err:
        message = str(err)
        assert "\n" not in message and family.__name__ in message, message
        return
    _usable(prior)


# ----------------------------------------------------------------- cases found, kept explicitly
@pytest.mark.parametrize("make, fragment", [
    (lambda: Gamma("abc", 1.0), "Gamma"),
    (lambda: Normal(0.0, "x"), "Normal"),
    (lambda: Uniform(0.0, math.inf), "Uniform"),
    (lambda: Normal(0.0, 1.0, bounds=(0.0, math.inf), plausible=(1.0, math.inf)), "Normal"),
])
def test_found_python_cases(make, fragment: str) -> None:
    with pytest.raises((ValueError, TypeError), match=fragment):
        make()
