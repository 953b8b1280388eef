"""The joint prior and the parameter split of a Problem."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import stats

from torchshm import Gamma, Normal, Problem, Uniform
from torchshm.problem import JointPrior, ParameterSplit


def test_log_prob_is_the_sum_of_the_scipy_densities() -> None:
    prior = JointPrior({"a": Uniform(1.0, 3.0), "b": Normal(2.0, 0.5), "c": 4.0}, ["a", "b"])
    theta = np.array([[1.5, 2.2], [2.9, 1.0]])
    expected = stats.uniform(1.0, 2.0).logpdf(theta[:, 0]) + stats.norm(2.0, 0.5).logpdf(theta[:, 1])
    np.testing.assert_allclose(prior.log_prob(theta), expected, rtol=1e-12)
    assert isinstance(prior.log_prob(torch.as_tensor(theta)), torch.Tensor)
    assert prior.log_prob(np.array([0.5, 2.0])) == -np.inf


def test_samples_follow_each_marginal() -> None:
    prior = JointPrior({"a": Uniform(1.0, 3.0), "b": Gamma(4.0, 2.0)}, ["a", "b"])
    draws = prior.sample(20_000, 0)
    assert draws.shape == (20_000, 2)
    assert stats.kstest(draws[:, 0], stats.uniform(1.0, 2.0).cdf).pvalue > 1e-3
    assert abs(draws[:, 1].mean() - 2.0) < 0.03  # Gamma(shape 4, rate 2): mean 2, sd 1


def test_missing_or_densityless_prior_is_named() -> None:
    with pytest.raises(ValueError, match="'b'"):
        JointPrior({"a": Uniform(0.0, 1.0)}, ["a", "b"])
    with pytest.raises(ValueError, match="no log_prob"):
        JointPrior({"a": 1.0}, ["a"])


def test_split_fills_fixed_values_in_model_order() -> None:
    priors = {"E": Uniform(1.0, 2.0), "K": 7.0, "sigma_a": Uniform(0.0, 1.0), "length": 0.3}
    split = ParameterSplit.from_priors(priors, ["K", "E"], has_length=True)
    assert split.names == ("E", "sigma_a")
    assert split.statistical_names == ("sigma_a", "length") and split.fixed == {"K": 7.0, "length": 0.3}
    theta_p, sigma_a, length = split.split(np.array([[1.5, 0.2], [1.7, 0.4]]))
    np.testing.assert_array_equal(theta_p.numpy(), [[7.0, 1.5], [7.0, 1.7]])
    np.testing.assert_array_equal(sigma_a.numpy(), [0.2, 0.4])
    np.testing.assert_array_equal(length.numpy(), [0.3, 0.3])
    assert ParameterSplit.from_priors(priors, ["K", "E"], has_length=False).split(
        np.array([[1.5, 0.2]])
    )[2] is None


def test_problem_uses_its_joint_prior(small) -> None:
    model, data = small
    priors = {"E_c": Uniform(30.0, 45.0), "log10_K_r": 8.0, "sigma_a": Uniform(0.0, 5.0),
              "length": Uniform(0.01, 2.0)}
    problem = Problem(model, data, priors=priors)
    theta = problem.sample_prior(5, 1)
    np.testing.assert_array_equal(problem.log_prior(theta), problem.prior.log_prob(theta))
    np.testing.assert_array_equal(problem.hard_bounds, problem.prior.hard_bounds)
    assert problem.split.names == tuple(problem.names) == ("E_c", "sigma_a", "length")
    assert problem.split.physical(theta)[:, 1].unique().tolist() == [8.0]
