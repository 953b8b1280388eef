"""The O(n) state-space density and draws equal the dense Eq. (21) Gaussian.

Oracles: the dense path of :func:`torchshm.log_likelihood` and an independent numpy/scipy
computation (covariance from the closed-form kernels, ``scipy.stats.multivariate_normal``).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import stats

import torchshm
from torchshm.kernels import get_kernel
from torchshm.likelihood import marginal, statespace
from torchshm.likelihood.marginal import Eq21, choose_method

MARKOV = ["exponential", "matern32", "matern52"]


def scipy_log_likelihood(y, eta, x, kernel, sigma_a, length, sigma_m, sigma_e) -> float:
    """Independent dense computation in numpy/scipy (no torchshm code)."""
    d = np.abs(x[:, None] - x[None, :]) / length
    if kernel == "exponential":
        rho = np.exp(-d)
    elif kernel == "matern32":
        rho = (1 + np.sqrt(3) * d) * np.exp(-np.sqrt(3) * d)
    else:
        rho = (1 + np.sqrt(5) * d + 5 * d**2 / 3) * np.exp(-np.sqrt(5) * d)
    total = 0.0
    for y_l, eta_l in zip(y, eta):
        cov = sigma_a**2 * rho + np.diag(sigma_m**2 * eta_l**2 + sigma_e**2)
        total += stats.multivariate_normal.logpdf(y_l, eta_l, cov)
    return float(total)


def positions(n: int, rng: np.random.Generator) -> np.ndarray:
    """Irregular sorted positions over 35 m with repeated points."""
    x = np.sort(rng.uniform(35.0, 70.0, n))
    x[5:8] = x[5]  # three readings at one position
    x[-2] = x[-1]
    return x


@pytest.mark.parametrize("kernel", MARKOV)
@pytest.mark.parametrize("length", [1e-7, 0.3, 4.0, 1e5])
def test_matches_dense_and_scipy(kernel: str, length: float) -> None:
    rng = np.random.default_rng(3)
    n, n_loads = 400, 3
    x = positions(n, rng)
    eta = 40.0 * np.sin(x[None, :] / 3.0 + rng.uniform(0, 6, (n_loads, 1)))
    y = eta + rng.normal(0.0, 2.0, eta.shape)
    args = (y, eta, x, kernel, 2.5, length, 0.05, 0.1)
    fast = torchshm.log_likelihood(*args, method="state_space")
    dense = torchshm.log_likelihood(*args, method="dense")
    reference = scipy_log_likelihood(*args)
    assert float(fast) == pytest.approx(float(dense), rel=1e-9)
    assert float(fast) == pytest.approx(reference, rel=1e-9)


@pytest.mark.parametrize(
    ("kernel", "n"),
    [("exponential", 1000), ("matern52", 1000), pytest.param("matern32", 4000, marks=pytest.mark.slow)],
)
def test_large_n_matches_dense_batched(kernel: str, n: int) -> None:
    """Up to n = 4,000 (the acceptance size), a batch of parameter vectors, unsorted positions."""
    rng = np.random.default_rng(0)
    x = rng.permutation(positions(n, rng))
    eta = torch.as_tensor(30.0 * np.cos(x / 5.0))[None, None].expand(3, 1, n)
    y = eta[0] + torch.as_tensor(rng.normal(0.0, 1.0, (1, n)))
    sigma_a, length = torch.tensor([0.5, 3.0, 20.0]), torch.tensor([0.004, 1.0, 800.0])
    args = (y, eta, x, kernel, sigma_a, length, 0.05, 0.1)
    fast = torchshm.log_likelihood(*args, method="state_space")
    dense = torchshm.log_likelihood(*args, method="dense")
    torch.testing.assert_close(fast, dense, rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("kernel", MARKOV)
def test_gradient_matches_dense(kernel: str) -> None:
    rng = np.random.default_rng(1)
    x = positions(120, rng)
    y = torch.as_tensor(rng.normal(0.0, 3.0, (2, 120)))
    grads = []
    for method in ("state_space", "dense"):
        eta = torch.as_tensor(10.0 * np.sin(x / 2.0)).expand(2, 120).clone().requires_grad_(True)
        sa, ell = torch.tensor(1.7, requires_grad=True), torch.tensor(0.8, requires_grad=True)
        torchshm.log_likelihood(y, eta, x, kernel, sa, ell, 0.05, 0.1, method=method).backward()
        grads.append(torch.cat([eta.grad.reshape(-1), sa.grad[None], ell.grad[None]]))
    torch.testing.assert_close(grads[0], grads[1], rtol=1e-8, atol=1e-10)


def test_auto_picks_state_space_from_the_crossover() -> None:
    kern = get_kernel("matern32")
    assert choose_method(kern, marginal.STATE_SPACE_FROM - 1) == "dense"
    assert choose_method(kern, marginal.STATE_SPACE_FROM) == "state_space"
    assert choose_method(kern, 20_000, "dense") == "dense"  # asked for, and it fits
    with pytest.raises(ValueError, match="sigma_e > 0"):
        choose_method(kern, 10**6, noise_positive=False)  # no positive diagonal: dense refused
    assert choose_method(get_kernel("independent"), 10**6) == "diagonal"


def test_dense_too_large_is_one_line() -> None:
    with pytest.raises(ValueError, match=r"^10000000 points per load case: .*'squared_exponential'; use .*'matern32'") as err:
        choose_method(get_kernel("squared_exponential"), 10**7)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="no state-space form"):
        choose_method(get_kernel("squared_exponential"), 10, "state_space")


@pytest.mark.parametrize("kernel", ["exponential", "matern52"])
def test_state_space_draws_have_the_eq21_covariance(kernel: str) -> None:
    x = torch.tensor([0.0, 0.4, 0.4, 1.1, 2.0, 1.7])  # unsorted, one repeat
    eta_one = torch.tensor([[3.0, -2.0, 1.0, 0.0, 5.0, 2.0]], dtype=torch.float64)
    n = 40_000
    eta = eta_one.expand(n, 1, 6)
    sigma_a, length = torch.full((n,), 0.8), torch.full((n,), 1.2)
    gaussian = Eq21(eta, x.double(), get_kernel(kernel), sigma_a.double(), length.double(), 0.05, 0.1, "state_space")
    draws = gaussian.sample(torch.Generator().manual_seed(0))
    expected = get_kernel(kernel)(x, sigma_a=0.8, length=1.2) + torch.diag(0.05**2 * eta_one[0] ** 2 + 0.1**2)
    resid = (draws[:, 0] - eta_one[0]).numpy()
    np.testing.assert_allclose(resid.mean(0), 0.0, atol=0.03)
    np.testing.assert_allclose(np.cov(resid, rowvar=False), expected.numpy(), atol=0.04)


def test_draws_in_blocks_have_the_eq21_covariance(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of two positions (four blocks, one padded position): the same covariance."""
    monkeypatch.setattr(statespace, "draw_block_size", lambda n, columns: 2)
    x = torch.tensor([0.0, 0.3, 0.3, 0.9, 1.4, 2.6, 3.0], dtype=torch.float64)
    n = 40_000
    sigma_a, length = torch.full((n,), 0.8, dtype=torch.float64), torch.full((n,), 1.2, dtype=torch.float64)
    kern = get_kernel("matern32")
    draws = statespace.sample(x, kern, sigma_a, length, 1, torch.Generator().manual_seed(3))[:, 0]
    assert draws.shape == (n, 7)
    np.testing.assert_allclose(draws.mean(0).numpy(), 0.0, atol=0.03)
    np.testing.assert_allclose(np.cov(draws.numpy(), rowvar=False), kern(x, sigma_a=0.8, length=1.2).numpy(), atol=0.03)


def test_draws_reuse_noise_across_responses() -> None:
    x = torch.linspace(0.0, 3.0, 9, dtype=torch.float64)
    eta1 = torch.randn(20, 2, 9, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    kern, sa, ell = get_kernel("matern32"), torch.full((20,), 0.6), torch.full((20,), 1.0)
    d1 = Eq21(eta1, x, kern, sa, ell, 0.0, 0.1, "state_space").sample(torch.Generator().manual_seed(7))
    d2 = Eq21(eta1 + 0.5, x, kern, sa, ell, 0.0, 0.1, "state_space").sample(torch.Generator().manual_seed(7))
    torch.testing.assert_close(d2 - d1, torch.full_like(d1, 0.5))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_matches_cpu() -> None:
    rng = np.random.default_rng(2)
    x = positions(300, rng)
    eta = torch.as_tensor(10.0 * np.sin(x / 2.0))[None].expand(2, 300)
    y = eta + torch.as_tensor(rng.normal(0.0, 1.0, (2, 300)))
    cpu = torchshm.log_likelihood(y, eta, x, "matern32", 2.0, 1.0, method="state_space")
    gpu = torchshm.log_likelihood(y, eta.cuda(), x, "matern32", 2.0, 1.0, method="state_space")
    assert gpu.device.type == "cuda"
    torch.testing.assert_close(gpu.cpu(), cpu, rtol=1e-10, atol=0.0)


@pytest.mark.parametrize("kernel", MARKOV)
@pytest.mark.parametrize("n", [1, 2, 7, 64, 101])
def test_few_points_and_whole_blocks(kernel: str, n: int) -> None:
    """Sizes around the block layout: one point, whole blocks (64), a padded first block (101)."""
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(0.0, 5.0, n))
    eta = 20.0 * np.cos(x[None, :] + rng.uniform(0, 6, (2, 1)))
    y = eta + rng.normal(0.0, 1.5, eta.shape)
    args = (y, eta, x, kernel, 1.3, 0.7, 0.05, 0.2)
    fast = torchshm.log_likelihood(*args, method="state_space")
    assert float(fast) == pytest.approx(scipy_log_likelihood(*args), rel=1e-10)
    if n == 101:
        size = statespace.block_size(n, get_kernel(kernel).state_dim)
        assert n % size != 0  # the padded path is the one tested
