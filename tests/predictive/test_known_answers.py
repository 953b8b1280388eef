"""Bayes factors and KL divergence of real VBMC runs against closed-form answers.

Linear-Gaussian problems (tests/predictive/predictive_linear_gaussian.py): Matérn 3/2 and Matérn 5/2
discrepancies with fixed parameters, Normal priors; data drawn with a Matérn 3/2 discrepancy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import torchshm
from predictive_linear_gaussian import TwoShapeModel, analytic, make_problem, synthetic_data
from torchshm.predictive import bayes_factors, jeffreys_label, kl_divergence


def gaussian_kl(mean: np.ndarray, cov: np.ndarray, prior_mean: np.ndarray, prior_sd: float) -> float:
    """KL(N(mean, cov) || N(prior_mean, prior_sd² I)) [nats]."""
    d = prior_mean - mean
    k = mean.size
    return 0.5 * (np.trace(cov) / prior_sd**2 + d @ d / prior_sd**2 - k
                  + np.log(prior_sd ** (2 * k) / np.linalg.det(cov)))


@pytest.fixture(scope="module")
def runs() -> dict[str, tuple[object, object]]:
    model = TwoShapeModel()
    data = synthetic_data(model, seed=2)
    out = {}
    for kernel in ("matern32", "matern52"):
        problem = make_problem(kernel, 1.0, data, model)
        post = torchshm.identify(problem, method="vbmc", seed=0, display="off", n_samples=5000)
        out[kernel] = (post, analytic(problem))
    return out


@pytest.mark.slow
def test_bayes_factor_recovers_known_evidences(runs: dict) -> None:
    bf = bayes_factors({k: post for k, (post, _) in runs.items()})
    exact = (runs["matern32"][1].log_evidence - runs["matern52"][1].log_evidence) / math.log(10)
    assert abs(bf.log10[0, 1] - exact) < 0.1, (bf.log10[0, 1], exact)
    assert bf.labels[0][1] == jeffreys_label(exact) == "Substantial"
    assert bf.labels[1][0] == "Negative"


@pytest.mark.slow
def test_kl_divergence_of_vbmc_posterior(runs: dict) -> None:
    post, answer = runs["matern32"]
    estimate = kl_divergence(post, n=10_000, seed=0)
    exact = gaussian_kl(answer.mean, answer.cov, np.array([1.0, 2.0]), 1.0)
    assert abs(estimate.value - exact) < 0.05, (estimate, exact)
