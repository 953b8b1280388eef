"""Distance kernels of the model discrepancy Gaussian process (paper, Table 6)."""

from __future__ import annotations

from torchshm.kernels.base import MIN_LENGTH, Kernel
from torchshm.kernels.registry import KERNELS, get_kernel, kernel_names
from torchshm.kernels.stationary import (
    Exponential,
    Independent,
    Matern32,
    Matern52,
    SquaredExponential,
)
from torchshm.kernels.separable import SeparableExponential  # after KERNELS: the L1 exponential
from torchshm.kernels.upscaled import Upscaled  # after KERNELS (Table 6): a kernel of its own form

__all__ = [
    "KERNELS",
    "MIN_LENGTH",
    "Exponential",
    "Independent",
    "Kernel",
    "Matern32",
    "Matern52",
    "SeparableExponential",
    "SquaredExponential",
    "Upscaled",
    "get_kernel",
    "kernel_names",
]
