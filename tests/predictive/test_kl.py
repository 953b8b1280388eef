"""KL divergence from prior to posterior by Monte Carlo (Eq. 19) against analytic values."""

from __future__ import annotations

import numpy as np
import pytest

from doubles_predictive import GaussianPosterior, NormalPrior
from torchshm.predictive import kl_divergence


def gaussian_kl(mq: np.ndarray, cq: np.ndarray, mp: np.ndarray, sp: np.ndarray) -> float:
    """KL(N(mq, cq) || N(mp, diag(sp²)))."""
    cp = np.diag(sp**2)
    inv = np.linalg.inv(cp)
    d = mp - mq
    return 0.5 * (np.trace(inv @ cq) + d @ inv @ d - mq.size + np.log(np.linalg.det(cp) / np.linalg.det(cq)))


def test_matches_analytic_gaussian() -> None:
    # a linear-Gaussian problem: prior N(mp, sp²), y = A theta + e, exact Gaussian posterior
    rng = np.random.default_rng(0)
    mp, sp = np.array([10.0, 5.0, 1.0]), np.array([3.0, 2.0, 0.5])
    a = rng.standard_normal((30, 3))
    y = a @ np.array([11.0, 4.0, 1.2]) + 0.5 * rng.standard_normal(30)
    precision = np.diag(sp**-2) + a.T @ a / 0.25
    cq = np.linalg.inv(precision)
    mq = cq @ (mp / sp**2 + a.T @ y / 0.25)
    priors = {n: NormalPrior(m, s) for n, m, s in zip("abc", mp, sp)}
    priors["fixed"] = 0.3
    post = GaussianPosterior(list("abc"), mq, cq, priors=priors)
    estimate = kl_divergence(post, n=10_000, seed=0)
    exact = gaussian_kl(mq, cq, mp, sp)
    assert estimate.value == pytest.approx(exact, abs=0.05)
    assert estimate.se < 0.05 and estimate.n == 10_000


def test_equal_distributions_give_zero() -> None:
    post = GaussianPosterior(["a"], np.array([1.0]), np.array([[4.0]]), priors={"a": NormalPrior(1.0, 2.0)})
    assert abs(kl_divergence(post, n=2000).value) < 1e-10


def test_prior_without_log_prob() -> None:
    post = GaussianPosterior(["a"], np.array([1.0]), np.array([[4.0]]), priors={"a": 1.0})
    with pytest.raises(ValueError, match="no log_prob"):
        kl_divergence(post, n=10)


def test_estimate_is_a_number_with_its_error() -> None:
    from torchshm.predictive.kl import KLEstimate

    kl = KLEstimate(1.25, 0.01, 100)
    assert kl == 1.25 and kl > 1 and f"{kl:.1f}" == "1.2" and kl + 1 == 2.25
    assert (kl.value, kl.se, kl.n) == (1.25, 0.01, 100)


def test_emcee_posterior_gets_a_fitted_mixture_within_its_stated_error() -> None:
    """Samples only (no density): a held-out Gaussian mixture against the analytic KL."""
    from torchshm import Normal
    from torchshm.inference import Posterior

    mp, sp = np.array([10.0, 5.0, 1.0]), np.array([3.0, 2.0, 0.5])
    mq = np.array([10.5, 4.5, 1.1])
    cq = np.array([[0.2, 0.07, 0.0], [0.07, 0.1, 0.0], [0.0, 0.0, 0.01]])
    priors = {n: Normal(m, s) for n, m, s in zip("abc", mp, sp)}
    samples = np.random.default_rng(0).multivariate_normal(mq, cq, size=4000)
    post = Posterior(names=list("abc"), method="emcee", samples=samples, n_chains=4, priors=priors)
    kl = kl_divergence(post, seed=0)
    exact = gaussian_kl(mq, cq, mp, sp)  # 4.106 nats
    assert kl.source == "fitted mixture" and kl.n == 4000
    assert 0.0 <= kl.density_error < 0.05
    assert abs(kl.value - exact) < 3 * kl.se + kl.density_error, (kl, exact)
    with pytest.raises(ValueError, match="no density and 100 samples, too few"):
        kl_divergence(Posterior(names=list("abc"), method="emcee", samples=samples[:100], priors=priors))


def test_two_narrow_modes_get_the_kl_of_their_mixture() -> None:
    """Samples of two modes 30 sds apart: the held-out mixture has a component per mode (a
    shared scale per coordinate made it 1.8 nats low, with a density error of 0.016)."""
    from scipy.stats import multivariate_normal

    from torchshm import Normal
    from torchshm.inference import Posterior
    from torchshm.problem.prior import JointPrior

    priors = {n: Normal(m, s) for n, m, s in zip("abc", (10.0, 5.0, 1.0), (3.0, 2.0, 0.5))}
    m1, m2, cov = np.array([10.5, 4.5, 1.1]), np.array([13.5, 4.5, 1.1]), np.diag([0.01] * 3)
    rng = np.random.default_rng(1)
    samples = np.concatenate([rng.multivariate_normal(m1, cov, 4000), rng.multivariate_normal(m2, cov, 4000)])
    rng.shuffle(samples)
    log_q = np.logaddexp(multivariate_normal(m1, cov).logpdf(samples),
                         multivariate_normal(m2, cov).logpdf(samples)) - np.log(2.0)
    exact = float(np.mean(log_q - JointPrior(priors, list("abc")).log_prob(samples)))  # 6.256
    kl = kl_divergence(Posterior(names=list("abc"), method="emcee", samples=samples, n_chains=4,
                                 priors=priors), seed=0)
    assert abs(kl.value - exact) < 3 * kl.se + kl.density_error + 0.01, (kl, exact)
