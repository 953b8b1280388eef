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


def test_an_element_side_far_below_the_pitch_numbers_only_the_elements_seen() -> None:
    """An inferred ``length`` whose prior reaches towards 0 (a Gamma) asked for a grid of
    (extent / length)² columns (23 TiB at the plate's 2 m x 1.5 m and 1 µm) after the model
    runs; only the elements some point sees are columns, at most four a point."""
    from torchshm.kernels.upscaled import operator

    g = np.stack(np.meshgrid(np.linspace(0.0, 2.0, 16), np.linspace(0.0, 1.5, 12)), -1).reshape(-1, 2)
    u = operator(g, 1e-6)
    assert u.shape[0] == 192 and u.shape[1] <= 4 * 192
    assert np.allclose(np.asarray(u.sum(axis=1)).ravel(), 1.0)  # bilinear weights: rows sum to 1
