"""The table of distinct distances: the same covariances and gradients as the direct
computation, kept per points tensor and dropped when the points change."""

from __future__ import annotations

import pytest
import torch

from torchshm.kernels import get_kernel
from torchshm.kernels.base import distances
from torchshm.kernels.table import KEPT, _TABLES, distance_table

KERNELS = ["independent", "exponential", "matern32", "matern52", "squared_exponential", "separable_exponential"]
POINTS = {
    "fibre": torch.arange(351, dtype=torch.float64) * 0.1 + 35.0,
    "grid": torch.cartesian_prod(torch.arange(16.0) * 0.05, torch.arange(12.0) * 0.05).double(),
}


def _direct(kern, x, sigma_a, length):
    d = distances(x, x, l1=kern.l1)
    return sigma_a[:, None, None].square() * kern.correlation(d, length[:, None, None] if kern.has_length else None)


@pytest.mark.parametrize("where", list(POINTS))
@pytest.mark.parametrize("name", KERNELS)
def test_table_gives_the_direct_covariance_and_gradients(name: str, where: str) -> None:
    kern, x = get_kernel(name), POINTS[where]
    values, index = distance_table(x, l1=kern.l1)
    assert values.numel() < x.shape[0] ** 2 // 20  # few distinct distances on a fibre or a grid
    sigma_a = torch.tensor([1.0, 2.5], dtype=torch.float64, requires_grad=True)
    length = torch.tensor([0.3, 1.7], dtype=torch.float64, requires_grad=True)
    table, direct = kern(x, sigma_a=sigma_a, length=length), _direct(kern, x, sigma_a, length)
    assert torch.equal(table, direct)  # the same floating-point distances: the same values
    for a, b in zip(torch.autograd.grad(table.sum(), (sigma_a, length), allow_unused=True),
                    torch.autograd.grad(direct.sum(), (sigma_a, length), allow_unused=True)):
        if b is not None:  # sums in another order: 1e-12 relative
            torch.testing.assert_close(a, b, rtol=1e-12, atol=0.0)


def test_no_table_for_scattered_points_or_points_with_a_gradient() -> None:
    scattered = torch.rand(200, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    assert distance_table(scattered) is None  # distinct distances: the direct computation
    moving = POINTS["fibre"].clone().requires_grad_()
    assert distance_table(moving) is None
    kern = get_kernel("matern52")
    K = kern(moving, sigma_a=1.0, length=1.0)
    (grad,) = torch.autograd.grad(K[0, 1], moving)
    assert grad.abs().sum() > 0


def test_table_follows_changes_of_the_points() -> None:
    x = torch.arange(50, dtype=torch.float64) * 0.1
    kern = get_kernel("squared_exponential")
    before = kern(x, sigma_a=1.0, length=0.5)
    x.mul_(2.0)  # in place: a new version of the same tensor
    after = kern(x, sigma_a=1.0, length=0.5)
    torch.testing.assert_close(after, _direct(kern, x, torch.ones(1), torch.tensor([0.5]))[0], rtol=0, atol=0)
    assert not torch.equal(before, after)


def test_few_tables_are_kept() -> None:
    points = [torch.arange(30, dtype=torch.float64) * (i + 1) for i in range(KEPT + 3)]
    for x in points:
        distance_table(x)
    assert len(_TABLES) <= KEPT
