"""Kernels of the Euclidean distance between `n x d` coordinates, against scipy's ``cdist``."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.distance import cdist

from torchshm.kernels import KERNELS, get_kernel
from torchshm.kernels.base import distances

#: the paper's correlation functions of r = d / l, written independently of torchshm
FORMULAS = {
    "independent": lambda d, ell: (d == 0).astype(float),
    "exponential": lambda d, ell: np.exp(-d / ell),
    "matern32": lambda d, ell: (1 + np.sqrt(3) * d / ell) * np.exp(-np.sqrt(3) * d / ell),
    "matern52": lambda d, ell: (1 + np.sqrt(5) * d / ell + 5 * d**2 / (3 * ell**2))
    * np.exp(-np.sqrt(5) * d / ell),
    "squared_exponential": lambda d, ell: np.exp(-((d / ell) ** 2)),
}


def test_every_kernel_has_a_formula() -> None:
    assert set(FORMULAS) == set(KERNELS)


@pytest.mark.parametrize("dim", [2, 3])
def test_distances_equal_cdist(rng: np.random.Generator, dim: int) -> None:
    x1, x2 = rng.uniform(-2.0, 3.0, (40, dim)), rng.uniform(-2.0, 3.0, (25, dim))
    d = distances(torch.as_tensor(x1), torch.as_tensor(x2)).numpy()
    np.testing.assert_allclose(d, cdist(x1, x2), rtol=1e-12, atol=1e-12)
    same = distances(torch.as_tensor(x1), torch.as_tensor(x1)).numpy()
    assert np.all(np.diag(same) == 0.0) and np.array_equal(same, same.T)


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_on_coordinates_equals_formula_of_cdist(rng: np.random.Generator, name: str, dim: int) -> None:
    x1, x2 = rng.uniform(0.0, 2.0, (30, dim)), rng.uniform(0.0, 2.0, (20, dim))
    x2[:3] = x1[:3]  # coinciding points: d = 0
    for s, ell in [(0.9, 0.4), (3.0, 2.5)]:
        k = get_kernel(name)(torch.as_tensor(x1), torch.as_tensor(x2), sigma_a=s, length=ell)
        expected = s**2 * FORMULAS[name](cdist(x1, x2), ell)
        assert k.shape == (30, 20)
        np.testing.assert_allclose(k.numpy(), expected, rtol=1e-12, atol=1e-12 * s**2)


@pytest.mark.parametrize("name", KERNELS)
def test_one_dimensional_positions_are_unchanged(rng: np.random.Generator, name: str) -> None:
    """Positions `n` give bit for bit ``k(|x - x'|)``; `n x 1` coordinates the same values."""
    x = rng.uniform(0.0, 40.0, 50)
    kern = get_kernel(name)
    k = kern(torch.as_tensor(x), sigma_a=torch.tensor([0.7, 1.2]), length=torch.tensor([1.5, 0.3]))
    d = (torch.as_tensor(x)[:, None] - torch.as_tensor(x)[None, :]).abs()
    ell = torch.tensor([1.5, 0.3])[:, None, None] if kern.has_length else None
    expected = torch.tensor([0.7, 1.2])[:, None, None].square() * kern.correlation(d, ell)
    assert torch.equal(k, expected)
    column = kern(torch.as_tensor(x[:, None]), sigma_a=torch.tensor([0.7, 1.2]), length=torch.tensor([1.5, 0.3]))
    torch.testing.assert_close(column, k, rtol=1e-15, atol=0)


@pytest.mark.parametrize("name", ["exponential", "matern32", "matern52", "squared_exponential"])
def test_grid_covariance_is_positive_definite_batched(name: str) -> None:
    g = torch.linspace(0.0, 1.0, 8)
    xy = torch.cartesian_prod(g, g)  # 64 x 2 grid, 0.14 m pitch
    sigma_a, length = torch.tensor([0.5, 2.0]), torch.tensor([0.1, 0.3])
    k = get_kernel(name)(xy, sigma_a=sigma_a, length=length)
    assert k.shape == (2, 64, 64) and torch.equal(k, k.mT)
    assert int(torch.linalg.cholesky_ex(k + 1e-10 * torch.eye(64)).info.abs().sum()) == 0
    torch.testing.assert_close(get_kernel(name).diag(xy, sigma_a=sigma_a), k.diagonal(dim1=-2, dim2=-1))


def test_gradients_are_finite_at_coinciding_points() -> None:
    xy = torch.tensor([[0.0, 0.0], [0.3, 0.4], [0.3, 0.4]], requires_grad=True)
    length = torch.tensor(0.5, requires_grad=True)
    get_kernel("matern32")(xy, sigma_a=1.0, length=length).sum().backward()
    assert torch.isfinite(xy.grad).all() and torch.isfinite(length.grad)


@pytest.mark.parametrize(
    ("a", "b"), [((5, 2), (4, 3)), ((5,), (4, 2)), ((5, 2), (4,)), ((2, 5, 2), (2, 4, 2))]
)
def test_mismatched_positions_are_refused(a: tuple[int, ...], b: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match=r"kernel positions must be .*got x1"):
        get_kernel("matern32")(torch.zeros(a), torch.zeros(b), sigma_a=1.0, length=1.0)
