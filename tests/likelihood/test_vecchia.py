"""The Vecchia form of Eq. (21) on 2-D fields: exact with full conditioning sets, its measured
error with the default ones, gradients, masks through the blocks, and the predictive draws."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.distance import cdist
from scipy.stats import multivariate_normal

from torchshm.kernels import get_kernel
from torchshm.likelihood import blocks, marginal, vecchia
from torchshm.likelihood.gaussian import log_likelihood

KERNELS = ("exponential", "matern32", "matern52", "squared_exponential")


def _grid(side: int, spacing: float = 1.0) -> np.ndarray:
    g = spacing * np.arange(side, dtype=np.float64)
    return np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)


def _correlation(name: str, r: np.ndarray) -> np.ndarray:
    """Table 6 in numpy (``r = d / l``), independent of the torch kernels."""
    if name == "exponential":
        return np.exp(-r)
    if name == "matern32":
        return (1 + np.sqrt(3) * r) * np.exp(-np.sqrt(3) * r)
    if name == "matern52":
        return (1 + np.sqrt(5) * r + 5 * r**2 / 3) * np.exp(-np.sqrt(5) * r)
    return np.exp(-(r**2))


@pytest.mark.parametrize("name", KERNELS)
def test_full_conditioning_sets_give_scipys_density(name: str, rng: np.random.Generator) -> None:
    """m = n - 1: every conditional is exact, the product is the density (1e-9 relative)."""
    xy = rng.uniform(0.0, 2.0, (80, 2))
    eta = rng.normal(50.0, 20.0, (2, 2, 80))
    resid = rng.normal(0.0, 2.0, (2, 2, 80))
    sa, ell, sm, se = np.array([1.5, 4.0]), np.array([0.3, 1.1]), 0.03, 0.5
    noise = sm**2 * eta**2 + se**2
    got = vecchia.log_density(
        torch.as_tensor(resid), torch.as_tensor(noise), torch.as_tensor(xy), get_kernel(name),
        torch.as_tensor(sa), torch.as_tensor(ell), m=79,
    )
    for b in range(2):
        k = sa[b] ** 2 * _correlation(name, cdist(xy, xy) / ell[b])
        expected = sum(multivariate_normal(np.zeros(80), k + np.diag(noise[b, i])).logpdf(resid[b, i]) for i in range(2))
        assert float(got[b]) == pytest.approx(expected, rel=1e-9, abs=0)


def _field_case(name: str, side: int, pitch: float, length: float, hole: bool, seed: int) -> tuple:
    """A grid field (with a hole), heteroscedastic diagonal, y drawn from the exact Gaussian;
    also its exact log density, from the Cholesky factor the draw was made with
    (``-zᵀz/2 - Σ log L_ii - n log(2π)/2`` for ``y = eta + L z``)."""
    xy = _grid(side, pitch)
    if hole:  # a lost patch of subsets
        xy = xy[np.linalg.norm(xy - xy.mean(0), axis=1) > 0.2 * side * pitch]
    rng = np.random.default_rng(seed)
    x, eta = torch.as_tensor(xy), torch.as_tensor(rng.uniform(20.0, 100.0, (1, xy.shape[0])))
    noise = 0.05**2 * eta[None] ** 2 + 0.1**2
    cov = marginal.covariance(x, get_kernel(name), torch.tensor([2.0]), torch.tensor([length]), noise)
    factor = torch.linalg.cholesky(cov[0, 0])
    z = torch.as_tensor(rng.standard_normal(xy.shape[0]))
    y = eta + (factor @ z)[None]
    exact = -0.5 * z.square().sum() - factor.diagonal().log().sum() - 0.5 * z.shape[0] * np.log(2 * np.pi)
    return y, eta, x, float(exact)


@pytest.mark.parametrize(("name", "m", "bound"), [
    ("exponential", 30, 0.1), ("matern32", 30, 0.1), ("matern52", 30, 0.1), ("squared_exponential", 30, 0.1),
    ("exponential", None, 0.5), ("squared_exponential", None, 0.5),
])
def test_error_at_a_length_of_one_pitch(name: str, m: int | None, bound: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """1,370 points (40 x 40 grid with a hole), σa = 2 µε, σe = 0.1 µε, σm = 0.05, l = one
    pitch: |Δ log-likelihood| against dense <= 0.1 nat with m = 30, <= 0.5 nat with the default
    m. (Longer lengths: larger errors, measured in docs/likelihood.md.)"""
    if m is not None:
        monkeypatch.setitem(vecchia.NEIGHBOURS, name, m)
    y, eta, x, exact = _field_case(name, 40, 0.025, 0.025, hole=True, seed=3)
    dense = log_likelihood(y, eta, x, name, 2.0, 0.025, 0.05, 0.1, method="dense")
    assert float(dense) == pytest.approx(exact, rel=1e-10)  # the draw's own factor: the 10^4 test's reference
    approx = log_likelihood(y, eta, x, name, 2.0, 0.025, 0.05, 0.1, method="vecchia")
    assert abs(float(approx - dense)) <= bound


def test_gradients_match_finite_differences(rng: np.random.Generator) -> None:
    xy = torch.as_tensor(rng.uniform(0.0, 1.0, (300, 2)))
    eta0 = torch.as_tensor(rng.normal(40.0, 10.0, (2, 300)))
    y = eta0 + torch.as_tensor(rng.normal(0.0, 1.0, (2, 300)))

    def value(eta: torch.Tensor, sa: torch.Tensor, ell: torch.Tensor) -> torch.Tensor:
        return log_likelihood(y, eta, xy, "matern52", sa, ell, 0.05, 0.3, method="vecchia")

    params = [eta0.clone().requires_grad_(), torch.tensor(1.3, requires_grad=True), torch.tensor(0.2, requires_grad=True)]
    grads = torch.autograd.grad(value(*params), params)
    h = 1e-6
    for k, index in ((0, (1, 17)), (1, ()), (2, ())):
        up = [p.detach().clone() for p in params]
        down = [p.detach().clone() for p in params]
        up[k][index] += h
        down[k][index] -= h
        fd = float(value(*up) - value(*down)) / (2 * h)
        assert float(grads[k][index]) == pytest.approx(fd, rel=1e-5, abs=1e-6)


def test_masked_field_through_blocks_equals_dense_with_full_sets(monkeypatch: pytest.MonkeyPatch) -> None:
    """Dropouts of one load case: two blocks, each its own Vecchia plan (m = n - 1: exact)."""
    monkeypatch.setitem(vecchia.NEIGHBOURS, "matern32", 59)
    rng = np.random.default_rng(5)
    xy = _grid(8, 0.1)[:60]
    mask = np.ones((2, 60), dtype=bool)
    mask[1, [3, 10, 11, 40]] = False
    y = torch.as_tensor(rng.normal(0.0, 1.0, (2, 60)))
    eta = torch.as_tensor(rng.normal(30.0, 5.0, (3, 2, 60)))
    parts = blocks.make_blocks(xy, mask, {None: slice(0, 60)}, 0.2)
    s, ell = torch.tensor([[1.0], [2.0], [0.5]]), torch.tensor([[0.1], [0.3], [0.05]])
    got = blocks.blocks_log_likelihood(y, eta, parts, "matern32", s, ell, 0.05, method="vecchia")
    expected = blocks.blocks_log_likelihood(y, eta, parts, "matern32", s, ell, 0.05, method="dense")
    torch.testing.assert_close(got, expected, rtol=1e-10, atol=0)


def test_draws_with_full_sets_are_the_cholesky_draws(rng: np.random.Generator) -> None:
    """m = n - 1: the sparse factor is the Cholesky factor in Vecchia order, so the draw from
    standard normals z is that factor times z."""
    xy = torch.as_tensor(rng.uniform(0.0, 1.0, (50, 2)))
    z = torch.as_tensor(rng.standard_normal((2, 3, 50)))
    kern = get_kernel("matern32")
    sa, ell = torch.tensor([1.0, 3.0]), torch.tensor([0.2, 0.5])
    got = vecchia.sample(xy, kern, sa, ell, 0.01, z, m=49)
    order = vecchia.neighbours.plan(xy.numpy(), 49).order
    for b in range(2):
        cov = kern(xy[order], sigma_a=sa[b], length=ell[b]) + 0.01 * torch.eye(50)
        expected = torch.empty(3, 50, dtype=torch.float64)
        expected[:, order] = (torch.linalg.cholesky(cov) @ z[b].mT).mT
        torch.testing.assert_close(got[b], expected, rtol=1e-9, atol=1e-12)


def test_predictive_draws_of_a_large_field_have_the_model_covariance() -> None:
    """Eq21.sample at 6,400 points ("auto": full-scale, drawn from the Vecchia factor): per-point variance σa² + σe² (5 %)
    and the correlation of neighbours one pitch apart (0.02), pooled over 30 draws."""
    xy = torch.as_tensor(_grid(80, 0.01))
    eta = torch.zeros(30, 1, 6400, dtype=torch.float64)
    sa, ell = torch.full((30,), 2.0), torch.full((30,), 0.05)
    gaussian = marginal.Eq21(eta, xy, get_kernel("exponential"), sa, ell, 0.0, 0.3)
    assert gaussian.method == "fullscale"  # "auto": its draws are the Vecchia draws
    draws = gaussian.sample(torch.Generator().manual_seed(1)).reshape(30, 80, 80)
    assert float(draws.var()) == pytest.approx(4.0 + 0.09, rel=0.05)
    near = (draws[..., 1:] * draws[..., :-1]).mean() / draws.var()  # neighbours along x
    assert float(near) == pytest.approx(4.0 * np.exp(-0.2) / 4.09, abs=0.02)


@pytest.mark.slow
def test_ten_thousand_points_length_of_one_pitch_within_a_tenth_of_a_nat(monkeypatch: pytest.MonkeyPatch) -> None:
    """10^4 points (100 x 100 grid), Matérn 3/2, l = one pitch, m = 30: |Δ| <= 0.1 nat against
    the exact density, computed from the dense Cholesky factor the field was drawn with (equal
    to ``method="dense"`` to 1e-10 in the 1,370-point test above; a second 10^4 factorisation
    would double the test's time); ``method="auto"`` takes the Vecchia form at this size."""
    monkeypatch.setitem(vecchia.NEIGHBOURS, "matern32", 30)
    y, eta, x, exact = _field_case("matern32", 100, 0.01, 0.01, hole=False, seed=7)
    approx = log_likelihood(y, eta, x, "matern32", 2.0, 0.01, 0.05, 0.1)
    assert abs(float(approx) - exact) <= 0.1
