"""The variational posterior against the log joint at the evaluated points
(:mod:`torchshm.inference.vbmc_check`), on Gaussians whose evidence is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from torchshm.inference.vbmc_check import TOLERANCE, evaluated_excess


def _target(x: np.ndarray, log_z: float) -> np.ndarray:
    """An unnormalised 2-D Gaussian log joint of evidence ``exp(log_z)``: N(0, diag(1, 4))."""
    return log_z + multivariate_normal([0.0, 0.0], np.diag([1.0, 4.0])).logpdf(x)


def test_the_exact_posterior_explains_every_evaluated_point() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(0.0, [1.5, 3.0], size=(200, 2))  # a design wider than the posterior
    y = _target(x, -7.0)
    log_q = multivariate_normal([0.0, 0.0], np.diag([1.0, 4.0])).logpdf(x)
    got = evaluated_excess(x, y, log_q, -7.0, log_q)
    assert got.largest == pytest.approx(0.0, abs=1e-9)  # y - log q = log Z exactly
    assert got.n_over == 0 and got.n_bulk > 100


def test_a_posterior_too_narrow_along_one_axis_is_caught() -> None:
    """q has sd 0.5 where the posterior's is 2: at an evaluated point 4 sds of q out along that
    axis (1 posterior sd) the log joint exceeds log q + ELBO by 8 - 0.5 + log(1/4) + KL = 7.0
    nats; at the mode, by log(1/4) + KL = -0.5."""
    x = np.array([[0.0, 0.0], [0.0, 2.0], [1.0, 0.0]])
    y = _target(x, 0.0)
    q = multivariate_normal([0.0, 0.0], np.diag([1.0, 0.25]))
    elbo = -0.5 * (0.25 / 4.0 - 1.0 - np.log(0.25 / 4.0))  # the ELBO of q: log Z - KL(q || p)
    own = q.logpdf(q.rvs(2000, random_state=1))  # log q at q's own draws
    got = evaluated_excess(x, y, q.logpdf(x), elbo, own)
    want = y[1] - q.logpdf(x[1]) - elbo
    assert got.largest == pytest.approx(want) and want == pytest.approx(7.03, abs=0.01)
    assert want > TOLERANCE
    np.testing.assert_array_equal(got.where, x[1])
    assert got.n_over == 1 and got.n_bulk == 3


def test_points_in_the_far_tails_are_not_the_bulk() -> None:
    """A point 40 nats below the mode is not where the posterior's mass is, whatever q says
    there (a Gaussian mixture's tails are lighter than many posteriors' without that
    mattering)."""
    p = multivariate_normal([0.0, 0.0], np.diag([1.0, 4.0]))
    x = np.array([[0.0, 0.0], [9.0, 0.0]])
    y = _target(x, 0.0)
    log_q = np.array([y[0], -1e3])
    got = evaluated_excess(x, y, log_q, 0.0, p.logpdf(p.rvs(2000, random_state=2)))
    assert got.n_bulk == 1 and got.largest == pytest.approx(0.0)
    assert evaluated_excess(x[:0], y[:0], log_q[:0], 0.0, log_q).n_bulk == 0


def test_a_missed_better_mode_is_caught() -> None:
    """q sits on a mode 20 nats below the one VBMC also evaluated: there the log joint exceeds
    log q + ELBO by about 20 nats plus how far q's density has fallen."""
    q = multivariate_normal([0.0, 0.0], np.eye(2) * 0.01)
    x = np.array([[0.0, 0.0], [3.0, 3.0]])
    elbo = 0.0  # q explains the lesser mode, of evidence 1
    y = np.array([q.logpdf(x[0]), q.logpdf([0.0, 0.0]) + 20.0])  # the better mode's peak
    got = evaluated_excess(x, y, q.logpdf(x), elbo, q.logpdf(q.rvs(2000, random_state=3)))
    assert got.n_over == 1 and got.largest == pytest.approx(20.0 + 0.5 * 18.0 / 0.01)  # 920 nats
    np.testing.assert_array_equal(got.where, x[1])


def test_the_misfit_becomes_a_warning_line_of_the_posterior() -> None:
    from types import SimpleNamespace

    from torchshm.inference.checks import misfit, warning_tags

    d = {"misfit": True, "evaluated_over": 5, "evaluated_bulk": 350, "evaluated_excess": 4.24}
    line = misfit(SimpleNamespace(diagnostics=d))
    assert line.startswith("VBMC MISFIT: ") and "5 of the 350" in line and "4.24 nats" in line
    assert "method='emulator'" in line and warning_tags([line]) == "VBMC MISFIT"
    assert misfit(SimpleNamespace(diagnostics={**d, "misfit": False})) is None
    assert misfit(SimpleNamespace(diagnostics={})) is None  # emcee, emulator, older files
