"""The reduced-rank form of the squared exponential along a line against scipy's and the dense
Gaussian (torchshm/likelihood/hilbert.py)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats
import torch

from torchshm.kernels import get_kernel
from torchshm.likelihood import hilbert
from torchshm.likelihood.gaussian import log_likelihood
from torchshm.likelihood.marginal import HILBERT_FROM, choose_method

KERNEL = get_kernel("squared_exponential")
#: agreement asked of the log density [nat]; the dense Cholesky and scipy differ by up to 1e-6
#: here (log densities of order 1e3)
TOLERANCE = 1e-5


def _case(n: int, lengths: list[float], sigma_a: float, sigma_e: float, loads: int = 3, seed: int = 0):
    """Positions along 12 m, responses, and data drawn from Eq. (21) with the first length."""
    g = torch.Generator().manual_seed(seed)
    x = torch.linspace(0.0, 12.0, n, dtype=torch.float64)
    eta = 40.0 * torch.sin(x / 3.0) + torch.randn(len(lengths), loads, n, generator=g, dtype=torch.float64)
    cov = KERNEL(x, sigma_a=sigma_a, length=lengths[0]) + sigma_e**2 * torch.eye(n, dtype=torch.float64)
    y = eta[0] + (torch.linalg.cholesky(cov) @ torch.randn(n, loads, generator=g, dtype=torch.float64)).T
    return x, eta, y, torch.tensor(lengths, dtype=torch.float64)


def _scipy(x, eta, y, sigma_a, length, sigma_e):
    """Sum over load cases of scipy's log density (sigma_m = 0) for one row."""
    d = (x[:, None] - x[None]).numpy()
    cov = sigma_a**2 * np.exp(-(d / length) ** 2) + sigma_e**2 * np.eye(x.numel())
    return float(scipy.stats.multivariate_normal(np.zeros(x.numel()), cov).logpdf((y - eta).numpy()).sum())


@pytest.mark.parametrize(("sigma_a", "sigma_e"), [(1.0, 0.1), (3.0, 0.001)])
def test_equals_scipy_for_lengths_from_a_fortieth_of_the_line_to_twice_it(sigma_a: float, sigma_e: float) -> None:
    for length in (0.3, 0.6, 1.2, 3.0, 8.0, 24.0):  # data drawn with the length evaluated
        x, eta, y, lengths = _case(458, [length], sigma_a, sigma_e)
        assert bool(hilbert.fits(x, KERNEL, lengths).all())
        value = log_likelihood(y, eta, x, KERNEL, sigma_a, lengths, 0.0, sigma_e, method="hilbert")
        # rel: scipy's own rounding at sigma_a / sigma_e = 3000 (1.2e-5 of 7,416 nats seen in CI)
        assert float(value[0]) == pytest.approx(_scipy(x, eta[0], y, sigma_a, length, sigma_e), abs=TOLERANCE, rel=1e-8)


def test_value_and_gradient_equal_the_dense_form_with_a_multiplicative_term_and_extra_variance() -> None:
    x, eta, y, lengths = _case(300, [0.5, 0.9, 2.0, 5.0], 1.5, 0.1, seed=1)
    extra = 0.01 * torch.rand(eta.shape, generator=torch.Generator().manual_seed(2), dtype=torch.float64)
    grads = []
    for method in ("dense", "hilbert"):
        e, sa, ell = (eta.clone().requires_grad_(), torch.full((4,), 1.5, dtype=torch.float64, requires_grad=True),
                      lengths.clone().requires_grad_())
        value = log_likelihood(y, e, x, KERNEL, sa, ell, 0.05, 0.1, method=method, extra_variance=extra)
        grads.append([value.detach(), *torch.autograd.grad(value.sum(), [e, sa, ell])])
    for dense, reduced in zip(*grads):
        torch.testing.assert_close(reduced, dense, rtol=1e-7, atol=TOLERANCE)


def test_short_lengths_stay_dense_and_octaves_share_a_basis() -> None:
    """Rows of lengths over five octaves, two too short for a basis below SHARE of the points."""
    x, eta, y, lengths = _case(200, [0.05, 0.1, 1.0, 1.3, 2.9, 6.0], 1.0, 0.1, seed=3)
    fits = hilbert.fits(x, KERNEL, lengths)
    assert fits.tolist() == [False, False, True, True, True, True]
    dense = log_likelihood(y, eta, x, KERNEL, 1.0, lengths, 0.05, 0.1, method="dense")
    auto = log_likelihood(y, eta, x, KERNEL, 1.0, lengths, 0.05, 0.1)
    assert bool((dense[:2] == auto[:2]).all())  # the same dense computation
    torch.testing.assert_close(auto, dense, rtol=0.0, atol=TOLERANCE)


def test_basis_size_follows_the_spreads_of_the_length() -> None:
    """m = ceil(2 KAPPA (half range + MARGIN s) / (pi s)), s = length / sqrt(2)."""
    x = torch.linspace(-3.0, 9.0, 500, dtype=torch.float64)
    s = 1.0 / np.sqrt(2.0)
    expected = int(np.ceil(2 * hilbert.KAPPA * (6.0 + hilbert.MARGIN * s) / (np.pi * s)))
    assert int(hilbert.sizes(x, KERNEL, torch.tensor([1.0], dtype=torch.float64))[0]) == expected


def test_choice() -> None:
    assert choose_method(KERNEL, HILBERT_FROM - 1) == "dense"
    assert choose_method(KERNEL, HILBERT_FROM) == "hilbert"
    assert choose_method(KERNEL, HILBERT_FROM, noise_positive=False) == "dense"
    assert choose_method(KERNEL, HILBERT_FROM, "dense") == "dense"
    assert choose_method(KERNEL, 50, "hilbert") == "hilbert"
    with pytest.raises(ValueError, match="Gaussian spectral density"):
        choose_method(get_kernel("matern32"), 500, "hilbert")
    with pytest.raises(ValueError, match="Gaussian spectral density"):
        choose_method(KERNEL, 500, "hilbert", dim=2)


def test_predictive_draws_stay_dense() -> None:
    """The draws of a size where the likelihood takes the reduced rank are the dense draws."""
    from torchshm.predictive import predictive_draws

    x, eta, _, lengths = _case(150, [1.0, 2.0], 1.0, 0.1, seed=4)
    draws = [predictive_draws(eta, x, KERNEL, torch.ones(2, dtype=torch.float64), lengths, 0.05, 0.1,
                              torch.Generator().manual_seed(5), method=method) for method in ("auto", "dense")]
    assert choose_method(KERNEL, 150) == "hilbert"
    assert torch.equal(draws[0], draws[1])


def test_mixed_batch_keeps_the_vectors_order_and_gradients() -> None:
    """Vectors left dense and vectors of the reduced rank, interleaved, in chunks."""
    x, eta, y, _ = _case(200, [1.0] * 6, 1.0, 0.1, seed=6)
    lengths = torch.tensor([2.0, 0.05, 1.3, 0.1, 6.0, 0.07], dtype=torch.float64)
    grads = []
    for method in ("dense", "auto"):
        e, ell = eta.clone().requires_grad_(), lengths.clone().requires_grad_()
        value = log_likelihood(y, e, x, KERNEL, 1.0, ell, 0.05, 0.1, method=method)
        grads.append([value.detach(), *torch.autograd.grad(value.sum(), [e, ell])])
    for dense, auto in zip(*grads):
        torch.testing.assert_close(auto, dense, rtol=1e-7, atol=TOLERANCE)
    empty = log_likelihood(y, eta[:0], x, KERNEL, 1.0, lengths[:0], 0.05, 0.1)
    assert empty.shape == (0,)


def test_lengths_that_are_not_finite_or_negative_give_nan_as_the_dense_form_does() -> None:
    x, eta, y, _ = _case(200, [1.0] * 4, 1.0, 0.1, seed=7)
    lengths = torch.tensor([1.5, float("nan"), -1.0, float("inf")], dtype=torch.float64)
    auto = log_likelihood(y, eta, x, KERNEL, 1.0, lengths, 0.05, 0.1)
    dense = log_likelihood(y, eta, x, KERNEL, 1.0, lengths, 0.05, 0.1, method="dense")
    assert bool(torch.isfinite(auto[0])) and bool(torch.isnan(auto[1:]).all())
    torch.testing.assert_close(auto, dense, rtol=0.0, atol=TOLERANCE, equal_nan=True)
