"""A kernel class registers itself: one class is all it takes to add a kernel."""

from __future__ import annotations

import pytest
import torch

from torchshm.kernels import KERNELS, get_kernel, kernel_names
from torchshm.kernels.base import REGISTRY, Kernel, scaled_distance


@pytest.fixture
def cauchy():
    class Cauchy(Kernel):
        name = "cauchy_test"

        def correlation(self, d, length):
            return 1.0 / (1.0 + scaled_distance(d, length).square())

    yield Cauchy
    REGISTRY.pop("cauchy_test", None)


def test_table_6_kernels_are_registered_in_order() -> None:
    assert KERNELS == ("independent", "exponential", "matern32", "matern52", "squared_exponential")
    assert kernel_names()[:5] == KERNELS


def test_new_kernel_registers_itself(cauchy) -> None:
    assert "cauchy_test" in kernel_names()
    k = get_kernel("cauchy_test")
    assert isinstance(k, cauchy)
    cov = k([0.0, 2.0], sigma_a=2.0, length=2.0)
    assert torch.allclose(cov, torch.tensor([[4.0, 2.0], [2.0, 4.0]], dtype=torch.float64))


def test_subclass_without_its_own_name_is_not_registered() -> None:
    before = kernel_names()

    class Helper(Kernel):  # e.g. a mixin base of several kernels
        def correlation(self, d, length):
            return d

    assert kernel_names() == before


def test_taken_name_is_refused() -> None:
    with pytest.raises(TypeError, match="already taken"):
        class Other(Kernel):
            name = "matern32"

            def correlation(self, d, length):
                return d
