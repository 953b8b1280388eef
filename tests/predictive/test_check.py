"""The emulator check of Fig. 7: draws on and outside the 99 % region, emulator against model."""

from __future__ import annotations

import numpy as np
from scipy import stats

from doubles_predictive import linear_setup
from torchshm.predictive import emulator_check


def test_groups_and_errors() -> None:
    problem, post = linear_setup(n_design=30)
    problem.hard_bounds = np.array([[-100.0, 100.0]] * len(problem.names))
    check = emulator_check(post, [20.0, 30.0], n_points=20, n_pool=4000)
    log_q_b = post.log_pdf(check.boundary_theta)
    log_q_o = post.log_pdf(check.outside_theta)
    # a Gaussian's 99 % region: log q >= log q(mean) - chi2_D(0.99) / 2
    threshold = post.log_pdf(post.mean[None])[0] - 0.5 * stats.chi2(len(post.names)).ppf(0.99)
    assert np.all(np.abs(log_q_b - threshold) < 0.5)
    assert check.outside_theta.shape[0] == 20 and np.all(log_q_o < threshold + 0.5)
    assert check.boundary_exact.shape == (20, 2, problem.measurements.n)
    # a linear model is emulated exactly, on the boundary and outside
    assert check.boundary_error < 1e-3 and check.outside_error < 1e-2
