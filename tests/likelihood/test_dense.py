"""The dense log density's closed-form gradient against autograd and finite differences."""

from __future__ import annotations

import math

import pytest
import torch

from torchshm.likelihood import log_likelihood
from torchshm.likelihood.dense import dense_log_density


def _plain(cov: torch.Tensor, resid: torch.Tensor) -> torch.Tensor:
    """The same density through autograd's Cholesky (the reference)."""
    chol = torch.linalg.cholesky(cov)
    z = torch.linalg.solve_triangular(chol, resid.unsqueeze(-1), upper=False)
    log_det = 2.0 * chol.diagonal(dim1=-2, dim2=-1).log().sum(-1).sum(-1)
    log_det = log_det * (resid.shape[1] / cov.shape[1])
    n = resid.shape[1] * resid.shape[2]
    return -0.5 * (z.square().sum((-1, -2, -3)) + log_det + n * math.log(2 * math.pi))


def _covariances(b: int, shared: int, n: int, gen: torch.Generator) -> torch.Tensor:
    a = torch.randn(b, shared, n, n, generator=gen, dtype=torch.float64)
    return a @ a.mT / n + 0.5 * torch.eye(n, dtype=torch.float64)


@pytest.mark.parametrize("shared", [1, 3])
def test_value_and_gradients_match_autograd(shared: int) -> None:
    gen = torch.Generator().manual_seed(3)
    cov = _covariances(4, shared, 12, gen).requires_grad_(True)
    resid = torch.randn(4, 3, 12, generator=gen, dtype=torch.float64).requires_grad_(True)
    weights = torch.randn(4, generator=gen, dtype=torch.float64)
    got = dense_log_density(cov, resid)
    want = _plain(cov, resid)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-10)
    g_cov, g_res = torch.autograd.grad((got * weights).sum(), (cov, resid))
    w_cov, w_res = torch.autograd.grad((want * weights).sum(), (cov, resid))
    torch.testing.assert_close(g_res, w_res, rtol=1e-10, atol=1e-10)
    # autograd's Cholesky gradient is the symmetric part: compare symmetric parts
    torch.testing.assert_close(g_cov, 0.5 * (w_cov + w_cov.mT), rtol=1e-9, atol=1e-10)


def test_gradcheck_finite_differences() -> None:
    gen = torch.Generator().manual_seed(5)
    base = _covariances(2, 2, 5, gen)
    resid = torch.randn(2, 2, 5, generator=gen, dtype=torch.float64).requires_grad_(True)
    half = torch.randn(2, 2, 5, 5, generator=gen, dtype=torch.float64).requires_grad_(True)

    def f(h: torch.Tensor, r: torch.Tensor) -> torch.Tensor:
        return dense_log_density(base + 0.05 * (h + h.mT), r)  # a symmetric perturbation

    assert torch.autograd.gradcheck(f, (half, resid), eps=1e-6, atol=1e-6)


def test_failed_factor_gives_minus_inf_and_no_gradient() -> None:
    gen = torch.Generator().manual_seed(7)
    cov = _covariances(2, 1, 6, gen)
    cov[1] = torch.nan  # no jitter helps
    cov.requires_grad_(True)
    resid = torch.randn(2, 2, 6, generator=gen, dtype=torch.float64).requires_grad_(True)
    value = dense_log_density(cov, resid)
    assert torch.isfinite(value[0]) and value[1] == -torch.inf
    total = torch.where(torch.isfinite(value), value, 0.0).sum()
    g_cov, g_res = torch.autograd.grad(total, (cov, resid))
    assert torch.isfinite(g_cov).all() and torch.isfinite(g_res).all()
    assert (g_cov[1] == 0).all() and (g_res[1] == 0).all()


def test_wrong_number_of_covariances_is_refused() -> None:
    with pytest.raises(ValueError, match="2 covariances for 3 load cases"):
        dense_log_density(torch.eye(4).expand(1, 2, 4, 4), torch.zeros(1, 3, 4))


@pytest.mark.parametrize("sigma_m", [0.05, 0.0])
def test_likelihood_gradient_in_strains_and_kernel_parameters(sigma_m: float) -> None:
    """Through ``log_likelihood``'s dense form: the gradient in the strains, σa and l equals
    the one of the same Gaussian written with autograd's Cholesky (independent path)."""
    gen = torch.Generator().manual_seed(11)
    x = torch.sort(torch.rand(30, generator=gen, dtype=torch.float64) * 10).values
    eta = (20 * torch.randn(3, 2, 30, generator=gen, dtype=torch.float64)).requires_grad_(True)
    y = eta.detach()[0] + torch.randn(2, 30, generator=gen, dtype=torch.float64)
    s = torch.tensor([0.5, 1.0, 2.0], dtype=torch.float64, requires_grad=True)
    ell = torch.tensor([0.5, 2.0, 4.0], dtype=torch.float64, requires_grad=True)
    got = log_likelihood(y, eta, x, "squared_exponential", s, ell, sigma_m, 0.1, "dense")
    grads = torch.autograd.grad(got.sum(), (eta, s, ell))
    d = (x[:, None] - x[None]).abs()
    k = s[:, None, None] ** 2 * torch.exp(-((d / ell[:, None, None]) ** 2))
    cov = k[:, None] + torch.diag_embed(sigma_m**2 * eta.square() + 0.01)
    want = _plain(cov, y - eta)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-9)
    for g, w in zip(grads, torch.autograd.grad(want.sum(), (eta, s, ell)), strict=True):
        torch.testing.assert_close(g, w, rtol=1e-8, atol=1e-9)
