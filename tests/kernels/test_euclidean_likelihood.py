"""Eq. (21) on `n x d` coordinates: the dense Gaussian of the Euclidean-distance kernel, and its limits."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.distance import cdist
from scipy.stats import multivariate_normal

from torchshm.kernels import get_kernel
from torchshm.likelihood import choice, marginal
from torchshm.likelihood.gaussian import log_likelihood


def test_field_log_likelihood_equals_scipy(rng: np.random.Generator) -> None:
    """Matérn 3/2 of the planar distance, multiplicative error and noise: scipy's density at 1e-10."""
    xy = rng.uniform(0.0, 2.0, (60, 2))
    eta = rng.normal(50.0, 20.0, (2, 60))
    y = eta + rng.normal(0.0, 3.0, (2, 60))
    s, ell, sm, se = 4.0, 0.3, 0.02, 3.0
    r = np.sqrt(3.0) * cdist(xy, xy) / ell
    k = s**2 * (1.0 + r) * np.exp(-r)
    expected = sum(multivariate_normal(eta[i], k + np.diag(sm**2 * eta[i] ** 2 + se**2)).logpdf(y[i]) for i in range(2))
    value = log_likelihood(y, eta, xy, "matern32", s, ell, sigma_m=sm, sigma_e=se)
    assert float(value) == pytest.approx(expected, rel=1e-10, abs=0)


def test_field_is_dense_below_the_vecchia_size_and_fullscale_from_it() -> None:
    kern = get_kernel("matern32")
    assert marginal.choose_method(kern, marginal.VECCHIA_FROM - 1, "auto", dim=2) == "dense"
    assert marginal.choose_method(kern, marginal.VECCHIA_FROM, "auto", dim=2) == "fullscale"
    assert marginal.choose_method(kern, marginal.VECCHIA_FROM, "vecchia", dim=2) == "vecchia"
    assert marginal.choose_method(kern, 10**6, "auto", dim=1) == "state_space"
    with pytest.raises(ValueError, match="method='vecchia' is for n x d coordinates"):
        marginal.choose_method(kern, 10**4, "vecchia", dim=1)
    with pytest.raises(ValueError, match="2-D coordinates: no state-space form"):
        log_likelihood(torch.zeros(1, 3), torch.zeros(1, 3), torch.zeros(3, 2), "matern32", 1.0, 1.0,
                       method="state_space")


def test_too_large_field_is_one_line_with_size_and_alternatives(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(choice, "_physical_memory", lambda: 2**30)  # a 1 GiB machine
    with pytest.raises(ValueError) as err:
        marginal.choose_method(get_kernel("matern32"), 10_000, "dense", dim=2)
    text = str(err.value)
    assert "\n" not in text and text.startswith("10000 points per load case: a dense covariance needs 1.5 GiB of 1.0 GiB")
    assert "2-D coordinates: use method='fullscale' (low rank + nearest neighbours) or fewer" in text
    assert "state space) or fewer points (a coarser pitch)" in str(
        pytest.raises(ValueError, marginal.choose_method, get_kernel("squared_exponential"), 10_000, "auto").value
    )
