"""The full-scale (low rank + Vecchia) form of Eq. (21) on 2-D fields: exact with full
conditioning sets, within 0.1 nat of the dense value and of scipy in the hard regime (long
lengths, small noise), differentiable, and what ``method="auto"`` takes."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.distance import cdist
from scipy.stats import multivariate_normal

from torchshm.kernels import get_kernel
from torchshm.likelihood import fullscale, fullscale_choice, marginal
from torchshm.likelihood.gaussian import log_likelihood

KERNELS = ("exponential", "matern32", "matern52", "squared_exponential")


def _correlation(name: str, r: np.ndarray) -> np.ndarray:
    """Table 6 in numpy (``r = d / l``), independent of the torch kernels."""
    if name == "exponential":
        return np.exp(-r)
    if name == "matern32":
        return (1 + np.sqrt(3) * r) * np.exp(-np.sqrt(3) * r)
    if name == "matern52":
        return (1 + np.sqrt(5) * r + 5 * r**2 / 3) * np.exp(-np.sqrt(5) * r)
    return np.exp(-(r**2))


def _field(side: int, seed: int) -> np.ndarray:
    """A `side x side` grid of the unit square with a round hole (lost subsets)."""
    g = np.linspace(0.0, 1.0, side)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    return xy[np.linalg.norm(xy - [0.3, 0.6], axis=1) > 0.12]


@pytest.mark.parametrize("name", KERNELS)
def test_full_sets_and_low_rank_give_scipys_density(name: str, rng: np.random.Generator) -> None:
    """m = n - 1 and rank 20: the Woodbury identity is exact, whatever the rank (1e-9 relative)."""
    xy = rng.uniform(0.0, 2.0, (90, 2))
    eta = rng.normal(50.0, 20.0, (2, 2, 90))
    resid = rng.normal(0.0, 2.0, (2, 2, 90))
    sa, ell, sm, se = np.array([1.5, 4.0]), np.array([0.3, 1.1]), 0.03, 0.5
    noise = sm**2 * eta**2 + se**2
    got = fullscale.log_density(
        torch.as_tensor(resid), torch.as_tensor(noise), torch.as_tensor(xy), get_kernel(name),
        torch.as_tensor(sa), torch.as_tensor(ell), m=89, rank=20,
    )
    for b in range(2):
        k = sa[b] ** 2 * _correlation(name, cdist(xy, xy) / ell[b])
        expected = sum(multivariate_normal(np.zeros(90), k + np.diag(noise[b, i])).logpdf(resid[b, i]) for i in range(2))
        assert float(got[b]) == pytest.approx(expected, rel=1e-9, abs=0)


@pytest.mark.parametrize("name", KERNELS)
def test_hard_regime_within_a_tenth_of_a_nat_of_dense_and_scipy(name: str) -> None:
    """1,107 points (a 34 x 34 grid with a hole), the rank and neighbours chosen per call: l = half the
    field (17 pitches), σa = 5 µε, σe = 0.05 µε (the priors' largest signal, smallest noise),
    σm = 0.05, y drawn from the exact Gaussian: |Δ| <= 0.1 nat against the dense path and
    ``scipy.stats.multivariate_normal.logpdf``; plain Vecchia (m = 10) is more than 1 nat off."""
    xy = _field(34, 0)
    n = xy.shape[0]
    rng = np.random.default_rng(11)
    eta = rng.uniform(20.0, 100.0, (1, n))
    cov = 25.0 * _correlation(name, cdist(xy, xy) / 0.5) + np.diag(0.05**2 * eta[0] ** 2 + 0.05**2)
    y = eta + np.linalg.cholesky(cov) @ rng.standard_normal(n)
    scipy_value = multivariate_normal(eta[0], cov).logpdf(y[0])
    args = (torch.as_tensor(y), torch.as_tensor(eta), torch.as_tensor(xy), name, 5.0, 0.5, 0.05, 0.05)
    dense = float(log_likelihood(*args, method="dense"))
    approx = float(log_likelihood(*args, method="fullscale"))
    assert dense == pytest.approx(scipy_value, rel=1e-10)
    assert abs(approx - dense) <= 0.1
    assert abs(approx - scipy_value) <= 0.1
    assert abs(float(log_likelihood(*args, method="vecchia")) - dense) > 1.0  # what the low rank fixes


def test_gradients_match_finite_differences(rng: np.random.Generator) -> None:
    xy = torch.as_tensor(rng.uniform(0.0, 1.0, (300, 2)))
    eta0 = torch.as_tensor(rng.normal(40.0, 10.0, (2, 300)))
    y = eta0 + torch.as_tensor(rng.normal(0.0, 1.0, (2, 300)))
    kern = get_kernel("matern52")

    def value(eta: torch.Tensor, sa: torch.Tensor, ell: torch.Tensor) -> torch.Tensor:
        noise = 0.05**2 * eta.square() + 0.3**2
        return fullscale.log_density((y - eta)[None], noise[None], xy, kern, sa.reshape(1), ell.reshape(1), m=8, rank=30)[0]

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


def test_auto_takes_the_full_scale_form_for_large_fields() -> None:
    kern = get_kernel("matern32")
    assert marginal.choose_method(kern, marginal.VECCHIA_FROM, dim=2) == "fullscale"
    assert marginal.choose_method(kern, marginal.VECCHIA_FROM - 1, dim=2) == "dense"
    assert marginal.choose_method(kern, 10**6, method="vecchia", dim=2) == "vecchia"
    with pytest.raises(ValueError, match="n x d coordinates"):
        marginal.choose_method(kern, 100, method="fullscale", dim=1)
    assert fullscale.rank_for(10**6, marginal.FULLSCALE_RANK) == fullscale.FACTOR_BYTES // (8 * 10**6)


@pytest.mark.parametrize(
    ("name", "ell", "sa", "rank", "m"),
    [
        ("squared_exponential", 1.0, 1.0, (1, 60), fullscale_choice.NEIGHBOURS_RESOLVED),  # long, smooth: few pivots
        ("matern52", 1.0, 1.0, (1, 200), fullscale_choice.NEIGHBOURS_RESOLVED),
        ("exponential", 0.01, 5.0, (0, 0), fullscale_choice.NEIGHBOURS_MAX),  # half a pitch: no pivots, most neighbours
    ],
)
def test_adaptive_choice_is_what_the_field_needs_and_within_a_tenth_of_a_nat(
    name: str, ell: float, sa: float, rank: tuple[int, int], m: int
) -> None:
    """919 points (a 32 x 32 grid with a hole, pitch 0.032), sigma_e = 0.05 µε, sigma_m = 0.05:
    the pivots stop by their residual (few at long smooth lengths, none at a third of a pitch,
    where they would buy nothing), the neighbours follow, and the value is within 0.1 nat of
    the exact one (scipy; y drawn from the exact Gaussian). The cap (512 pivots, 30
    neighbours) is the hard-regime test's case."""
    xy = _field(32, 0)
    n = xy.shape[0]
    rng = np.random.default_rng(5)
    eta = rng.uniform(20.0, 100.0, (1, n))
    cov = sa**2 * _correlation(name, cdist(xy, xy) / ell) + np.diag(0.05**2 * eta[0] ** 2 + 0.05**2)
    y = eta + np.linalg.cholesky(cov) @ rng.standard_normal(n)
    x = torch.as_tensor(xy)
    noise = torch.as_tensor(0.05**2 * eta**2 + 0.05**2)[None]
    _, pivots, choice = fullscale.setting(x, get_kernel(name), torch.tensor([sa]), torch.tensor([ell]), noise)
    assert rank[0] <= pivots.numel() <= rank[1]
    assert choice.neighbours == m
    assert choice.resolved == (m == fullscale_choice.NEIGHBOURS_RESOLVED)
    args = (torch.as_tensor(y), torch.as_tensor(eta), x, name, sa, ell, 0.05, 0.05)
    exact = multivariate_normal(eta[0], cov).logpdf(y[0])
    assert abs(float(log_likelihood(*args, method="fullscale")) - exact) <= 0.1
