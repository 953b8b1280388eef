"""The upscaled-field form of Eq. (21) (kernel ``upscaled``): its operator against a direct
bilinear interpolation, its sparse density against scipy's dense Gaussian, refusals, and the
covariance of its predictive draws."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.ndimage import map_coordinates
from scipy.stats import multivariate_normal

from torchshm.kernels import get_kernel
from torchshm.likelihood import marginal, upscaled
from torchshm.likelihood.gaussian import log_likelihood

ELEMENT = 0.012  # m


def _field(nx: int = 5, ny: int = 4, factor: int = 3) -> np.ndarray:
    """`n x 2` points of a field upscaled ``factor`` times from `nx x ny` element centres."""
    step = ELEMENT / factor
    gx, gy = np.meshgrid(0.05 + step * np.arange((nx - 1) * factor + 1),
                         0.03 + step * np.arange((ny - 1) * factor + 1), indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def test_operator_is_the_bilinear_upscaling(rng: np.random.Generator) -> None:
    """``U e`` equals scipy's bilinear interpolation of the element values (muDIC's upscaling)."""
    values = rng.normal(size=(5, 4))
    u = upscaled.operator(_field(), ELEMENT)
    f = np.arange(13) / 3, np.arange(10) / 3
    gx, gy = np.meshgrid(*f, indexing="ij")
    expected = map_coordinates(values, [gx, gy], order=1).ravel()
    assert u.shape == (130, 20)
    np.testing.assert_allclose(u @ values.ravel(), expected, atol=1e-12)


def test_sparse_density_is_scipys_dense_gaussian(rng: np.random.Generator) -> None:
    """Woodbury through the elements = the dense N(eta, sa² U Uᵀ + diag) (1e-9 relative), with a
    hole in the field and sigma_m > 0 (a diagonal per load case)."""
    x = np.delete(_field(), [17, 18, 40], axis=0)
    n = x.shape[0]
    eta = rng.normal(300.0, 200.0, (3, 2, n))
    y = rng.normal(300.0, 200.0, (2, n))
    sa, sm, se = np.array([150.0, 300.0, 600.0]), 0.05, 20.0
    got = log_likelihood(torch.tensor(y), torch.tensor(eta), torch.tensor(x), "upscaled", torch.tensor(sa),
                         torch.full((3,), ELEMENT), sigma_m=sm, sigma_e=se)
    u = upscaled.operator(x, ELEMENT).toarray()
    for b in range(3):
        want = sum(multivariate_normal(eta[b, k], sa[b] ** 2 * u @ u.T + np.diag(se**2 + (sm * eta[b, k]) ** 2)
                                       ).logpdf(y[k]) for k in range(2))
        assert float(got[b]) == pytest.approx(want, rel=1e-9)


def test_auto_takes_the_sparse_form_and_refuses_what_it_cannot_do() -> None:
    kern = get_kernel("upscaled")
    assert marginal.choose_method(kern, 10**6, dim=2) == "upscaled"
    with pytest.raises(ValueError, match="sigma_e > 0"):
        marginal.choose_method(kern, 100, noise_positive=False, dim=2)
    with pytest.raises(ValueError, match="n x 2"):
        marginal.choose_method(kern, 100, dim=1)


def test_draws_have_the_covariance_of_the_density() -> None:
    """4000 draws: empirical covariance within 5 % (of the largest entry) of sa² U Uᵀ + se² I."""
    x = _field(3, 3)
    n = x.shape[0]
    gen = torch.Generator().manual_seed(3)
    eta = torch.zeros(4000, 1, n, dtype=torch.float64)
    draws = marginal.Eq21(eta, torch.tensor(x), get_kernel("upscaled"),
                          torch.full((4000,), 100.0), torch.full((4000,), ELEMENT), 0.0, 5.0).sample(gen)
    u = upscaled.operator(x, ELEMENT).toarray()
    want = 100.0**2 * u @ u.T + 25.0 * np.eye(n)
    got = np.cov(draws[:, 0].numpy().T)
    assert np.abs(got - want).max() < 0.05 * want.max()
