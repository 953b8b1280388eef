"""Predictive draws have the covariance of Eq. (21) and reuse their noise across calls."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.kernels import get_kernel
from torchshm.predictive.draws import equal_tailed, predictive_draws


@pytest.mark.parametrize("kernel", ["independent", "exponential", "matern52"])
def test_empirical_covariance_matches_eq21(kernel: str) -> None:
    x = torch.linspace(0.0, 2.0, 5)
    eta_one = torch.tensor([[3.0, -2.0, 1.0, 0.0, 5.0]])
    n = 40_000
    eta = eta_one.expand(n, 1, 5)
    sigma_a, length = torch.full((n,), 0.8), torch.full((n,), 1.2)
    draws = predictive_draws(eta, x, kernel, sigma_a, length, 0.05, 0.1, torch.Generator().manual_seed(0))
    expected = get_kernel(kernel)(x, sigma_a=0.8, length=1.2) + torch.diag(0.05**2 * eta_one[0] ** 2 + 0.1**2)
    resid = (draws[:, 0] - eta_one[0]).numpy()
    empirical = np.cov(resid, rowvar=False)
    np.testing.assert_allclose(resid.mean(0), 0.0, atol=0.03)
    np.testing.assert_allclose(empirical, expected.numpy(), atol=0.04)


def test_same_generator_same_noise() -> None:
    x = torch.linspace(0.0, 3.0, 7)
    eta1 = torch.randn(50, 2, 7, generator=torch.Generator().manual_seed(1))
    eta2 = eta1 + 0.5
    sa, ell = torch.full((50,), 0.6), torch.full((50,), 1.0)
    d1 = predictive_draws(eta1, x, "matern32", sa, ell, 0.0, 0.1, torch.Generator().manual_seed(7))
    d2 = predictive_draws(eta2, x, "matern32", sa, ell, 0.0, 0.1, torch.Generator().manual_seed(7))
    torch.testing.assert_close(d2 - d1, torch.full_like(d1, 0.5))


def test_equal_tailed_quantiles() -> None:
    samples = torch.arange(1001, dtype=torch.float64)[:, None].expand(1001, 3)
    mean, lower, upper = equal_tailed(samples)
    torch.testing.assert_close(mean, torch.full((3,), 500.0))
    torch.testing.assert_close(lower, torch.full((3,), 25.0))
    torch.testing.assert_close(upper, torch.full((3,), 975.0))
