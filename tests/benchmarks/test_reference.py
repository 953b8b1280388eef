"""The suite's reference log joint (:mod:`benchmarks.reference`)."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.cases import make_problem
from benchmarks.catalog import CASES
from benchmarks.reference import direct_log_joint


def test_the_reference_log_joint_is_minus_infinity_outside_the_prior() -> None:
    """``direct_log_joint`` keeps -inf outside the prior's support (not the most negative
    float), so a sampler or an optimiser sees the bound for what it is."""
    problem = make_problem(CASES["beam2_user_gamma"])
    log_joint = direct_log_joint(problem)
    inside = np.asarray(problem.plausible_bounds).mean(1)
    outside = inside.copy()
    outside[0] = np.asarray(problem.hard_bounds)[0, 0] - 1.0
    values = log_joint(np.stack([inside, outside]))
    assert math.isfinite(values[0]) and values[1] == -math.inf
