"""Uniform, Gamma and Normal priors against scipy, with truncation to hard bounds."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import integrate, stats

from torchshm import Gamma, Normal, Uniform
from torchshm.priors import PLAUSIBLE_QUANTILES, Prior

CASES = [
    (Uniform(10.0, 100.0), stats.uniform(10.0, 90.0)),
    (Gamma(2.0, 2.0), stats.gamma(2.0, scale=0.5)),
    (Gamma(2.0, 2.0, bounds=(0.0, 5.0)), stats.gamma(2.0, scale=0.5)),
    (Gamma(3.0, 1.0, bounds=(0.5, 4.0)), stats.gamma(3.0, scale=1.0)),
    (Gamma(0.7, 3.0, bounds=(0.1, 2.0)), stats.gamma(0.7, scale=1 / 3.0)),
    (Normal(1.0, 0.5), stats.norm(1.0, 0.5)),
    (Normal(1.0, 0.5, bounds=(0.0, 1.2)), stats.norm(1.0, 0.5)),
]


def truncated_logpdf(dist, lo: float, hi: float, x: np.ndarray) -> np.ndarray:
    mass = dist.cdf(hi) - dist.cdf(lo)
    inside = (x >= lo) & (x <= hi)
    with np.errstate(divide="ignore"):
        return np.where(inside, dist.logpdf(x) - np.log(mass), -np.inf)
# the same names in every test process (pytest-xdist compares the collections)
CASE_IDS = [f"{i}-{prior!r}" for i, (prior, _) in enumerate(CASES)]


@pytest.mark.parametrize(("prior", "dist"), CASES, ids=CASE_IDS)
def test_log_prob_matches_truncated_scipy(prior: Prior, dist, rng: np.random.Generator) -> None:
    lo, hi = prior.hard_bounds
    span_lo, span_hi = max(lo, dist.ppf(1e-4)), min(hi, dist.ppf(1 - 1e-4))
    x = np.concatenate([rng.uniform(span_lo - 1, span_hi + 1, 200), [lo, hi]])
    x = x[np.isfinite(x)]
    got = prior.log_prob(x)
    assert isinstance(got, np.ndarray)
    np.testing.assert_allclose(got, truncated_logpdf(dist, lo, hi, x), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(("prior", "dist"), CASES, ids=CASE_IDS)
def test_density_integrates_to_one_on_hard_bounds(prior: Prior, dist) -> None:
    lo, hi = prior.hard_bounds
    lo, hi = max(lo, dist.ppf(1e-15)), min(hi, dist.ppf(1 - 1e-15))
    total, _ = integrate.quad(lambda t: float(np.exp(prior.log_prob(t))), lo, hi, limit=200)
    assert total == pytest.approx(1.0, abs=1e-8)


@pytest.mark.parametrize(("prior", "dist"), CASES, ids=CASE_IDS)
def test_samples_follow_the_truncated_distribution(prior: Prior, dist) -> None:
    lo, hi = prior.hard_bounds
    draws = prior.sample(4000, np.random.default_rng(7))
    assert draws.shape == (4000,) and (draws >= lo).all() and (draws <= hi).all()
    mass = dist.cdf(hi) - dist.cdf(lo)
    result = stats.kstest(draws, lambda t: (dist.cdf(np.clip(t, lo, hi)) - dist.cdf(lo)) / mass)
    assert result.pvalue > 1e-3
    assert np.array_equal(draws, prior.sample(4000, 7))  # a seed or a Generator


@pytest.mark.parametrize(("prior", "dist"), CASES, ids=CASE_IDS)
def test_default_plausible_bounds_are_the_central_68_percent(prior: Prior, dist) -> None:
    lo, hi = prior.hard_bounds
    mass = dist.cdf(hi) - dist.cdf(lo)
    want = dist.ppf(dist.cdf(lo) + np.array(PLAUSIBLE_QUANTILES) * mass)
    np.testing.assert_allclose(prior.plausible_bounds, want, rtol=1e-10)


def test_normal_default_plausible_is_one_sd() -> None:
    np.testing.assert_allclose(Normal(3.0, 2.0).plausible_bounds, (1.0, 5.0), rtol=1e-12)


def test_torch_in_torch_out_with_gradient() -> None:
    x = torch.tensor([0.5, 1.0, 7.0, -1.0], requires_grad=True)
    lp = Gamma(3.0, 1.0, bounds=(0.0, 10.0)).log_prob(x)
    assert isinstance(lp, torch.Tensor) and lp[2:].tolist() == [lp[2].item(), -np.inf]
    lp[:3].sum().backward()
    np.testing.assert_allclose(
        x.grad.numpy(), [2 / 0.5 - 1, 2 / 1.0 - 1, 2 / 7.0 - 1, 0.0], rtol=1e-14
    )


def test_outside_and_nan_are_minus_inf() -> None:
    for prior in (Uniform(0, 1), Gamma(2, 2, bounds=(0, 5)), Normal(0, 1, bounds=(-1, 1))):
        assert (prior.log_prob(np.array([-2.0, 7.0, np.nan, np.inf, -np.inf])) == -np.inf).all()


def test_zero_density_edge_is_minus_inf_not_nan() -> None:
    assert Gamma(2.0, 2.0, bounds=(0.0, 5.0)).log_prob(0.0) == -np.inf
    assert np.isfinite(Gamma(1.0, 2.0, bounds=(0.0, 5.0)).log_prob(0.0))  # exponential: 0 * log 0
    assert Gamma(0.5, 2.0).log_prob(0.0) == np.inf


def test_explicit_plausible_bounds_are_kept() -> None:
    assert Uniform(10, 100, plausible=(20, 60)).plausible_bounds == (20.0, 60.0)
    assert Gamma(2, 2, bounds=(0, 5), plausible=(0.2, 2.0)).plausible_bounds == (0.2, 2.0)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Uniform(5.0, 1.0), r"Uniform\(a, b\).*lo < hi"),
        (lambda: Uniform(1.0, 1.0), r"Uniform\(a, b\).*lo < hi"),
        (
            lambda: Uniform(0.0, 1.0, plausible=(0.5, 2.0)),
            "plausible bounds .* outside the hard bounds",
        ),
        (lambda: Uniform(0.0, 1.0, plausible=(0.8, 0.2)), "plausible bounds must satisfy lo < hi"),
        (lambda: Gamma(0.0, 1.0), "alpha"),
        (lambda: Gamma(2.0, -1.0), "beta"),
        (lambda: Gamma(2.0, 2.0, bounds=(5.0, 0.0)), "bounds must satisfy lo < hi"),
        (lambda: Gamma(2.0, 2.0, bounds=(-1.0, 5.0)), "outside the support"),
        (lambda: Gamma(2.0, 2.0, bounds=(0.0, 5.0), plausible=(0.2, 6.0)), "plausible"),
        (lambda: Normal(0.0, 0.0), "sd"),
        (lambda: Normal(0.0, -1.0), "sd"),
        (lambda: Normal(float("nan"), 1.0), "mean"),
        (lambda: Normal(0.0, 1.0, bounds=(50.0, 60.0)), "no probability"),
        (lambda: Normal(0.0, 1.0, bounds=(1.0,)), "pair"),
    ],
)
def test_bad_input_is_named(make, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()
