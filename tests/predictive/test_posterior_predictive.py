"""Posterior predictive without model evaluations, against the exact predictive (Sec. 2.4.1)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from doubles_predictive import linear_setup
from torchshm.predictive import exact_predictive, posterior_predictive


def test_makes_no_model_call() -> None:
    problem, post = linear_setup()
    problem.model.calls = 0
    pred = posterior_predictive(post, [20.0, 30.0], n=300)
    assert problem.model.calls == 0
    assert pred.mean.shape == (2, problem.measurements.n)
    assert pred.samples.shape == (300, 2, problem.measurements.n)
    assert torch.allclose(pred.x, torch.as_tensor(problem.measurements.x))
    assert pred.loads.tolist() == [20.0, 30.0]
    assert bool((pred.lower < pred.mean).all()) and bool((pred.mean < pred.upper).all())


@pytest.mark.parametrize("kernel", ["independent", "matern32", "squared_exponential"])
def test_matches_exact_predictive_on_linear_model(kernel: str) -> None:
    problem, post = linear_setup(kernel)
    pred = posterior_predictive(post, [10.0, 20.0, 30.0], n=500, seed=3)
    exact = exact_predictive(post, [10.0, 20.0, 30.0], n=500, seed=3)
    assert not pred.surrogate_variance_used
    assert pred.max_surrogate_sd < 0.01
    np.testing.assert_allclose(pred.theta, exact.theta)
    for name in ("mean", "lower", "upper"):
        gap = (getattr(pred, name) - getattr(exact, name)).abs().max().item()
        assert gap < 0.01, f"{name} differs by {gap} µε"


def test_model_positions() -> None:
    problem, post = linear_setup()
    pred = posterior_predictive(post, 20.0, n=200, positions="model")
    assert pred.mean.shape == (1, problem.model.x.numel())


def test_point_posterior_gives_analytic_interval() -> None:
    problem, post = linear_setup("independent")
    post.cov = post.cov * 1e-12  # theta fixed at the mean
    post._dist = None
    pred = posterior_predictive(post, [20.0], n=20_000, seed=1)
    eta = problem.model(torch.tensor(post.mean[:2]))[1, ::2]
    sd = (problem.sigma_m**2 * eta**2 + post.mean[2] ** 2 + problem.sigma_e**2).sqrt()
    assert (pred.mean[0] - eta).abs().max() < 4 * sd.max() / np.sqrt(20_000) * 1.5
    assert (pred.upper[0] - (eta + 1.96 * sd)).abs().max() < 0.05 * sd.max()
    assert (pred.lower[0] - (eta - 1.96 * sd)).abs().max() < 0.05 * sd.max()


def test_surrogate_variance_auto_and_forced() -> None:
    problem, post = linear_setup(n_design=4, design_sd=30.0, seed=2)
    pred = posterior_predictive(post, [20.0], n=200)
    assert pred.surrogate_variance_used and pred.max_surrogate_sd > 0.01
    off = posterior_predictive(post, [20.0], n=200, include_surrogate_variance=False)
    assert not off.surrogate_variance_used
    assert off.width.mean() < pred.width.mean()


def test_errors() -> None:
    problem, post = linear_setup()
    with pytest.raises(ValueError, match="unknown load case 99"):
        posterior_predictive(post, [99.0], n=10)
    with pytest.raises(ValueError, match="include_surrogate_variance"):
        posterior_predictive(post, [20.0], n=10, include_surrogate_variance="yes")
    post.problem = None
    with pytest.raises(ValueError, match="carries no Problem"):
        posterior_predictive(post, [20.0], n=10)
    problem._theta, problem._outputs = [], []
    with pytest.raises(ValueError, match="no stored model evaluations"):
        posterior_predictive(post, [20.0], n=10, problem=problem)


def test_fixed_parameter_taken_from_priors() -> None:
    problem, post = linear_setup()
    problem.priors["length"] = 1.5
    problem.names = ["a", "b", "sigma_a"]
    post.names, post.mean, post.cov = problem.names, post.mean[:3], post.cov[:3, :3]
    pred = posterior_predictive(post, [20.0], n=100)
    assert pred.theta.shape == (100, 3)
