"""Kernel ``separable_exponential``: the exponential of the L1 distance (one exponential per
direction), registered after the paper's Table 6, and ``exponential`` itself along a line."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import torchshm
from torchshm.config.schema import KernelName
from torchshm.kernels import KERNELS, get_kernel, kernel_names
from torchshm.likelihood import marginal, statespace

NAME = "separable_exponential"


def test_registered_after_table_6_and_offered_to_the_command_line() -> None:
    assert NAME in kernel_names() and NAME not in KERNELS
    assert KernelName[NAME].value == NAME


def test_field_covariance_is_the_exponential_of_the_l1_distance(rng: np.random.Generator) -> None:
    """sa² exp(-(|dx| + |dy|)/l) (numpy), the product of one exponential per direction, for a
    batch of (sa, l); symmetric positive definite."""
    x = rng.uniform(0.0, 0.4, (40, 2))
    sa, ell = np.array([[2.0], [0.5]]), np.array([[0.05], [0.3]])
    got = get_kernel(NAME)(torch.tensor(x), sigma_a=torch.tensor(sa), length=torch.tensor(ell))
    assert got.shape == (2, 1, 40, 40)
    l1 = np.abs(x[:, None, :] - x[None, :, :]).sum(-1)
    exp = get_kernel("exponential")
    for b in range(2):
        want = sa[b, 0] ** 2 * np.exp(-l1 / ell[b, 0])
        np.testing.assert_allclose(got[b, 0].numpy(), want, rtol=1e-13, atol=0)
        per_direction = exp(torch.tensor(x[:, 0]), sigma_a=sa[b, 0], length=ell[b, 0]) * exp(
            torch.tensor(x[:, 1]), sigma_a=1.0, length=ell[b, 0])
        torch.testing.assert_close(got[b, 0], per_direction, rtol=1e-13, atol=0)
        assert torch.linalg.eigvalsh(got[b, 0]).min() > 0
    cross = get_kernel(NAME)(torch.tensor(x[:5]), torch.tensor(x[5:9]), sigma_a=2.0, length=0.05)
    torch.testing.assert_close(cross, got[0, 0, :5, 5:9], rtol=1e-13, atol=0)


def test_along_a_line_it_is_the_exponential_and_its_state_space(rng: np.random.Generator) -> None:
    """1-D positions: the same matrix as ``exponential`` and the exact O(n) state space, whose
    value equals the dense one."""
    x = torch.tensor(np.sort(rng.uniform(0.0, 30.0, 1200)))
    kern = get_kernel(NAME)
    torch.testing.assert_close(kern(x[:50], sigma_a=3.0, length=2.0),
                               get_kernel("exponential")(x[:50], sigma_a=3.0, length=2.0), rtol=0, atol=0)
    assert statespace.is_markov(kern)
    assert marginal.choose_method(kern, x.numel(), "auto", dim=1, x=x) == "state_space"
    y = torch.tensor(rng.normal(0.0, 2.0, (2, 1200)))
    eta = torch.zeros(2, 2, 1200)
    sa, ell = torch.tensor([1.0, 3.0]), torch.tensor([0.5, 20.0])
    fast = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=0.0, sigma_e=0.3)
    dense = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=0.0, sigma_e=0.3, method="dense")
    same = torchshm.log_likelihood(y, eta, x, "exponential", sa, ell, sigma_m=0.0, sigma_e=0.3)
    torch.testing.assert_close(fast, dense, rtol=1e-10, atol=0)
    torch.testing.assert_close(fast, same, rtol=0, atol=0)


def test_refuses_a_missing_length_and_mismatched_coordinates() -> None:
    kern = get_kernel(NAME)
    with pytest.raises(ValueError, match="length"):
        kern(torch.zeros(3, 2), sigma_a=1.0, length=None)
    with pytest.raises(ValueError, match="coordinates"):
        kern(torch.zeros(3, 2), torch.zeros(3, 3), sigma_a=1.0, length=1.0)
