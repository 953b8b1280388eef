"""The returned draws of the emulator method in passes (:mod:`torchshm.inference.adaptive.draws`):
the Monte Carlo error of the moments, and more passes where a tail leaves them uncertain."""

from __future__ import annotations

import numpy as np
import pytest
from plateau_target import plateau
from scipy.stats import multivariate_normal

from torchshm.inference.adaptive.draws import MOMENT_TOL, moment_errors, posterior_draws

#: sd of y under :func:`plateau`: 97 % N(0, 0.3²) and 3 % uniform on 2..8
PLATEAU_SD = float(np.sqrt(0.97 * 0.09 + 0.03 * 28.0 - 0.15 ** 2))


def test_moment_errors_match_the_spread_over_seeds() -> None:
    # a Gaussian target, a Student-t proposal twice as wide: the delta method's sds of the
    # weighted mean and sd against their spread over 60 independent passes (within 25 %)
    from scipy.stats import multivariate_t

    target = multivariate_normal([0.0, 0.0], np.eye(2))
    proposal = multivariate_t([0.5, 0.0], 4.0 * np.eye(2), df=4)
    means, sds, predicted = [], [], []
    for seed in range(60):
        x = proposal.rvs(2000, random_state=seed)
        log_w = target.logpdf(x) - proposal.logpdf(x)
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        m = w @ x[:, 0]
        means.append(m)
        sds.append(np.sqrt(w @ np.square(x[:, 0] - m)))
        predicted.append(moment_errors(x[:, :1], log_w))
    assert np.median(predicted) == pytest.approx(max(np.std(means), np.std(sds)), rel=0.25)


def test_a_plateau_gets_more_passes_and_a_right_sd() -> None:
    # the chain holds the bump only; the plateau's 3 % sets most of y's variance, so one pass's
    # sd of y is uncertain: more passes, pooled; the sd within 10 % at each of three seeds and
    # their mean within 4 % (one pass's sd of y spreads by 4 % over seeds, the pooled by 2.5 %)
    hard = np.array([[-np.inf, np.inf], [-10.0, 10.0]])
    plausible = np.array([[-3.0, 3.0], [-9.0, 9.0]])
    rng = np.random.default_rng(7)
    chain = np.column_stack([rng.normal(0.0, 1.0, 4000), rng.normal(0.0, 0.3, 4000)])
    sds = []
    for seed in range(3):
        result, _, source, info = posterior_draws(plateau, chain, hard, plausible, 8000, seed)
        assert source == "importance" and info["importance_passes"] >= 1
        assert info["draws_moment_error"] <= max(MOMENT_TOL, 0.04)
        assert result.draws.shape == (8000, 2)
        sds.append(result.draws[:, 1].std())
        assert sds[-1] == pytest.approx(PLATEAU_SD, rel=0.1)
        assert result.log_z == pytest.approx(0.0, abs=0.03)  # the target is normalised
    assert np.mean(sds) == pytest.approx(PLATEAU_SD, rel=0.04)
