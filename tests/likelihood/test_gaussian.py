"""``log_likelihood`` (Eq. 21) against an independent dense scipy implementation."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import linalg, stats

import torchshm
from torchshm.kernels import KERNELS
from torchshm.likelihood import gaussian, log_likelihood
from torchshm.likelihood.cholesky import cholesky_with_jitter

FORMULAS = {
    "independent": lambda d, s, ell: s**2 * (d == 0),
    "exponential": lambda d, s, ell: s**2 * np.exp(-d / ell),
    "matern32": lambda d, s, ell: s**2 * (1 + np.sqrt(3) * d / ell) * np.exp(-np.sqrt(3) * d / ell),
    "matern52": lambda d, s, ell: (
        s**2 * (1 + np.sqrt(5) * d / ell + 5 * d**2 / (3 * ell**2)) * np.exp(-np.sqrt(5) * d / ell)
    ),
    "squared_exponential": lambda d, s, ell: s**2 * np.exp(-((d / ell) ** 2)),
}


def dense_log_likelihood(y, eta, x, kernel, s, ell, sigma_m, sigma_e) -> float:
    """What a user would write: one (L n x L n) block-diagonal covariance and scipy."""
    d = np.abs(x[:, None] - x[None, :])
    k = FORMULAS[kernel](d, s, ell)
    blocks = [np.diag(sigma_m**2 * eta_l**2) + k + sigma_e**2 * np.eye(x.size) for eta_l in eta]
    cov = linalg.block_diag(*blocks)
    return float(stats.multivariate_normal(mean=eta.ravel(), cov=cov).logpdf(y.ravel()))


@pytest.fixture
def data(rng: np.random.Generator) -> dict[str, np.ndarray]:
    x = np.sort(rng.uniform(35.0, 45.0, 40))  # irregular positions
    eta = rng.normal(0.0, 20.0, (4, 3, 40))
    y = eta[0] + rng.normal(0.0, 1.0, (3, 40))
    return {
        "x": x,
        "eta": eta,
        "y": y,
        "s": rng.uniform(0.2, 2.0, 4),
        "ell": rng.uniform(0.2, 5.0, 4),
    }


@pytest.mark.parametrize("sigma_m", [0.05, 0.0])
@pytest.mark.parametrize("kernel", KERNELS)
def test_matches_dense_scipy(kernel: str, sigma_m: float, data: dict[str, np.ndarray]) -> None:
    got = log_likelihood(
        data["y"],
        torch.as_tensor(data["eta"]),
        data["x"],
        kernel,
        torch.as_tensor(data["s"]),
        torch.as_tensor(data["ell"]),
        sigma_m=sigma_m,
        sigma_e=0.1,
    )
    assert got.shape == (4,) and got.dtype == torch.float64
    for b in range(4):
        want = dense_log_likelihood(
            data["y"], data["eta"][b], data["x"], kernel, data["s"][b], data["ell"][b], sigma_m, 0.1
        )
        assert abs(float(got[b]) - want) <= 1e-9 * abs(want)


def test_numpy_inputs_and_parameter_broadcasting(data: dict[str, np.ndarray]) -> None:
    """One prediction `L x n` against a batch of kernel parameters `2 x 3`."""
    s = data["s"][:3]
    got = log_likelihood(
        data["y"], data["eta"][1], data["x"], "matern52", s[None, :], np.array([[0.7], [2.0]])
    )
    assert isinstance(got, torch.Tensor) and got.shape == (2, 3)
    want = dense_log_likelihood(
        data["y"], data["eta"][1], data["x"], "matern52", s[2], 2.0, 0.05, 0.1
    )
    assert float(got[1, 2]) == pytest.approx(want, rel=1e-10)


def test_length_is_ignored_by_the_independent_kernel(data: dict[str, np.ndarray]) -> None:
    args = (data["y"], data["eta"][:2], data["x"], "independent", data["s"][:2])
    torch.testing.assert_close(log_likelihood(*args, None), log_likelihood(*args, data["ell"][:2]))


def test_chunked_batch_equals_one_chunk(
    data: dict[str, np.ndarray], monkeypatch: pytest.MonkeyPatch
) -> None:
    args = (data["y"], data["eta"], data["x"], "exponential", data["s"], data["ell"])
    whole = log_likelihood(*args)
    monkeypatch.setattr(gaussian, "CHUNK_BYTES", 1)  # one parameter vector per chunk
    torch.testing.assert_close(log_likelihood(*args), whole, rtol=1e-14, atol=0)


@pytest.mark.parametrize("kernel", KERNELS)
def test_gradients_match_finite_differences(kernel: str, rng: np.random.Generator) -> None:
    x = np.sort(rng.uniform(0.0, 3.0, 15))
    eta0 = rng.normal(0.0, 10.0, (2, 15))
    y = eta0 + rng.normal(0.0, 1.0, (2, 15))
    params = np.concatenate([eta0.ravel(), [0.8, 0.6]])

    def f(p: torch.Tensor) -> torch.Tensor:
        return log_likelihood(y, p[:30].reshape(2, 15), x, kernel, p[30], p[31])

    p = torch.as_tensor(params).requires_grad_(True)
    (grad,) = torch.autograd.grad(f(p), p)
    fd = np.empty_like(params)
    for i in range(params.size):
        h = 1e-6 * max(1.0, abs(params[i]))
        up, down = params.copy(), params.copy()
        up[i] += h
        down[i] -= h
        fd[i] = (float(f(torch.as_tensor(up))) - float(f(torch.as_tensor(down)))) / (2 * h)
    if kernel == "independent":
        assert grad[31] == 0 and fd[31] == 0  # no length
    np.testing.assert_allclose(grad.numpy(), fd, rtol=1e-5, atol=1e-7 * np.abs(fd).max())


@pytest.mark.parametrize("kernel", KERNELS)
def test_finite_values_and_gradients_at_zero_length_and_scale(kernel: str) -> None:
    x = np.arange(351) * 0.1 + 35.0
    eta = torch.full((2, 351), 5.0, requires_grad=True)
    sigma_a = torch.tensor([0.0, 0.0, 5.0, 5.0], requires_grad=True)
    length = torch.tensor([0.0, 10.0, 0.0, 10.0], requires_grad=True)
    value = log_likelihood(np.zeros((2, 351)), eta[None], x, kernel, sigma_a, length)
    value.sum().backward()
    assert torch.isfinite(value).all()
    for t in (eta, sigma_a) + ((length,) if kernel != "independent" else ()):
        assert torch.isfinite(t.grad).all()


def test_zero_length_equals_independent(data: dict[str, np.ndarray]) -> None:
    """With l = 0 no two distinct points are correlated: every kernel is ``independent``."""
    args = (data["y"], data["eta"], data["x"])
    want = log_likelihood(*args, "independent", data["s"], None)
    for kernel in KERNELS[1:]:
        torch.testing.assert_close(
            log_likelihood(*args, kernel, data["s"], 0.0), want, rtol=1e-12, atol=0
        )


def test_jitter_touches_only_the_failed_matrices() -> None:
    x = torch.arange(60) * 0.1
    k = torchshm.kernels.get_kernel("squared_exponential")(
        x, sigma_a=torch.tensor([1.0, 1.0]), length=torch.tensor([0.05, 5.0])
    )
    plain, info = torch.linalg.cholesky_ex(k)
    assert info.tolist()[0] == 0 and info.tolist()[1] != 0  # the smooth one is singular
    chol, failed = cholesky_with_jitter(k)
    assert not failed.any()
    assert torch.equal(chol[0], plain[0])  # untouched, bit for bit
    rebuilt = chol[1] @ chol[1].mT
    assert torch.allclose(rebuilt, k[1], atol=1e-4) and not torch.allclose(
        rebuilt, k[1], atol=0, rtol=0
    )


def test_singular_covariance_gives_finite_value_and_zero_covariance_gives_minus_inf() -> None:
    x = np.arange(60) * 0.1
    y = np.zeros((1, 60))
    singular = log_likelihood(y, np.zeros((1, 60)), x, "squared_exponential", 1.0, 5.0, 0.0, 0.0)
    assert torch.isfinite(singular)
    zero = log_likelihood(y, np.zeros((2, 1, 60)), x, "matern32", 0.0, 1.0, 0.0, 0.0)
    assert zero.tolist() == [-np.inf, -np.inf]
    zero = log_likelihood(y, np.zeros((1, 60)), x, "independent", 0.0, None, 0.0, 0.0)
    assert float(zero) == -np.inf


def test_negative_scale_or_length_gives_nan() -> None:
    y, eta, x = np.ones((2, 5)), np.zeros((2, 5)), np.arange(5.0)
    assert torch.isnan(log_likelihood(y, eta, x, "matern32", -1.0, 1.0))
    assert torch.isnan(log_likelihood(y, eta, x, "matern32", 1.0, -1.0))
    assert torch.isfinite(log_likelihood(y, eta, x, "independent", 1.0))


def test_nan_prediction_gives_nan() -> None:
    eta = np.ones((3, 2, 5))
    eta[1, 0, 2] = np.nan
    value = log_likelihood(np.ones((2, 5)), eta, np.arange(5.0), "matern32", 1.0, 1.0)
    assert torch.isnan(value[1]) and torch.isfinite(value[[0, 2]]).all()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"sigma_m": -0.1}, "sigma_m"),
        ({"sigma_e": -1.0}, "sigma_e"),
        ({"sigma_e": float("nan")}, "sigma_e"),
        ({"kernel": "rbf"}, "unknown kernel 'rbf'"),
        ({"eta": np.zeros((2, 3, 4))}, "eta must have shape"),
        ({"x": np.arange(4.0)}, "x must have shape"),
        ({"y": np.zeros(5)}, "y must have shape"),
        ({"y": np.zeros((2, 0)), "eta": np.zeros((2, 0)), "x": np.zeros(0)}, "y must have shape"),
        ({"length": None}, "kernel 'matern32' needs a length"),
        ({"sigma_e": None}, "sigma_e must be a number"),
        ({"eta": np.zeros((4, 2, 5)), "sigma_a": np.ones(3)}, "do not broadcast"),
    ],
)
def test_bad_input_is_named(kwargs: dict[str, object], message: str) -> None:
    args = {
        "y": np.zeros((2, 5)),
        "eta": np.zeros((2, 5)),
        "x": np.arange(5.0),
        "kernel": "matern32",
        "sigma_a": 1.0,
        "length": 1.0,
    }
    with pytest.raises(ValueError, match=message):
        log_likelihood(**{**args, **kwargs})
