"""The five covariance functions of the paper's Table 6 (``d = |x - x'|``, ``r = d / l``).

- ``independent``: ``sigma**2 * 1[d = 0]``
- ``exponential``: ``sigma**2 * exp(-r)``
- ``matern32``: ``sigma**2 * (1 + sqrt(3) r) * exp(-sqrt(3) r)``
- ``matern52``: ``sigma**2 * (1 + sqrt(5) r + 5 r**2 / 3) * exp(-sqrt(5) r)``
- ``squared_exponential``: ``sigma**2 * exp(-r**2)`` (no factor 1/2, as in the paper)
"""

from __future__ import annotations

import math

from torch import Tensor

from torchshm.kernels.base import Kernel, scaled_distance

SQRT3 = math.sqrt(3.0)
SQRT5 = math.sqrt(5.0)


class Independent(Kernel):
    """Independent discrepancy: ``sigma**2`` on coinciding points, 0 elsewhere (no length)."""

    name = "independent"
    has_length = False
    is_diagonal = True

    def correlation(self, d: Tensor, length: Tensor | None = None) -> Tensor:
        return (d == 0).to(d.dtype)


class Exponential(Kernel):
    """Exponential (Matérn 1/2) kernel ``sigma**2 * exp(-d / l)``."""

    name = "exponential"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        return (-scaled_distance(d, length)).exp()


class Matern32(Kernel):
    """Matérn kernel with ``nu = 3/2``: ``sigma**2 (1 + √3 d/l) exp(-√3 d/l)`` (paper, Eq. 9)."""

    name = "matern32"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        s = SQRT3 * scaled_distance(d, length)
        return (1.0 + s) * (-s).exp()


class Matern52(Kernel):
    """Matérn kernel with ``nu = 5/2``: ``sigma**2 (1 + √5 d/l + 5 d²/(3 l²)) exp(-√5 d/l)``."""

    name = "matern52"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        s = SQRT5 * scaled_distance(d, length)
        return (1.0 + s + s.square() / 3.0) * (-s).exp()


class SquaredExponential(Kernel):
    """Squared exponential kernel ``sigma**2 exp(-(d/l)²)``, without GPyTorch's factor 1/2."""

    name = "squared_exponential"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        return (-scaled_distance(d, length).square()).exp()
