"""Kernel ``upscaled``: registered after the paper's Table 6, offered to the command line, its
dense covariance ``sa² U Uᵀ`` and its refusals."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.config.schema import KernelName
from torchshm.kernels import KERNELS, get_kernel, kernel_names


def test_registered_but_not_in_table_6() -> None:
    assert "upscaled" in kernel_names() and "upscaled" not in KERNELS
    assert KernelName.upscaled.value == "upscaled"


def test_dense_covariance_of_centres_and_points_between() -> None:
    """Two centres 12 mm apart and the points at 1/3 and 2/3 between them: independent centres,
    (2/3, 1/3) weights between (variances 5/9, covariances from the shared elements)."""
    x = torch.tensor([[0.0, 0.0], [0.004, 0.0], [0.008, 0.0], [0.012, 0.0]], dtype=torch.float64)
    cov = get_kernel("upscaled")(x, sigma_a=torch.tensor([2.0, 1.0]), length=torch.tensor([0.012, 0.012]))
    w = np.array([[1, 0], [2 / 3, 1 / 3], [1 / 3, 2 / 3], [0, 1]])
    np.testing.assert_allclose(cov[1].numpy(), w @ w.T, atol=1e-12)
    np.testing.assert_allclose(cov[0].numpy(), 4 * w @ w.T, atol=1e-12)


def test_refusals() -> None:
    kern = get_kernel("upscaled")
    x = torch.zeros(3, 2, dtype=torch.float64)
    with pytest.raises(ValueError, match="two different point sets"):
        kern(x, x + 1.0, sigma_a=1.0, length=0.012)
    with pytest.raises(NotImplementedError):
        kern.correlation(torch.zeros(2, 2), torch.ones(1))
