"""The five covariance functions of the paper's Table 6 (``d = |x - x'|``, ``r = d / l``).

- ``independent``: ``sigma**2 * 1[d = 0]``
- ``exponential``: ``sigma**2 * exp(-r)``
- ``matern32``: ``sigma**2 * (1 + sqrt(3) r) * exp(-sqrt(3) r)``
- ``matern52``: ``sigma**2 * (1 + sqrt(5) r + 5 r**2 / 3) * exp(-sqrt(5) r)``
- ``squared_exponential``: ``sigma**2 * exp(-r**2)`` (no factor 1/2, as in the paper)
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from torchshm.kernels.base import Kernel, scaled_distance

SQRT3 = math.sqrt(3.0)
SQRT5 = math.sqrt(5.0)


def _state_space(
    rows: list[list[Tensor]], decay: Tensor, stationary: list[list[float]]
) -> tuple[Tensor, Tensor]:
    """Stack ``rows`` (polynomials of ``s``) into `... x p x p` transitions; the stationary
    covariance `p x p` of the scaled state (unit ``sigma``)."""
    F = torch.stack([torch.stack(r, dim=-1) for r in rows], dim=-2) * decay[..., None, None]
    return F, torch.tensor(stationary, dtype=F.dtype, device=F.device)


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
    #: dimension of the Markov state (the process itself), see :meth:`state_space`
    state_dim = 1

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        return (-scaled_distance(d, length)).exp()

    def state_space(self, d: Tensor, length: Tensor) -> tuple[Tensor, Tensor]:
        """Transitions `... x 1 x 1` over steps `d` [m] (`...`) and stationary covariance `1 x 1`
        of the state ``f`` at unit ``sigma_a``: ``f(x + d) = exp(-d/l) f(x) + q``."""
        s = scaled_distance(d, length)
        return _state_space([[torch.ones_like(s)]], (-s).exp(), [[1.0]])


class Matern32(Kernel):
    """Matérn kernel with ``nu = 3/2``: ``sigma**2 (1 + √3 d/l) exp(-√3 d/l)`` (paper, Eq. 9)."""

    name = "matern32"
    #: dimension of the Markov state ``(f, f' / lambda)``, ``lambda = sqrt(3) / l``
    state_dim = 2

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        s = SQRT3 * scaled_distance(d, length)
        return (1.0 + s) * (-s).exp()

    def state_space(self, d: Tensor, length: Tensor) -> tuple[Tensor, Tensor]:
        """Transitions `... x 2 x 2` over steps `d` [m] and stationary covariance `2 x 2` of the
        scaled state ``(f, f' / lambda)`` at unit ``sigma_a`` (``exp(A d)`` of the SDE, closed form)."""
        s = SQRT3 * scaled_distance(d, length)
        rows = [[1.0 + s, s], [-s, 1.0 - s]]
        return _state_space(rows, (-s).exp(), [[1.0, 0.0], [0.0, 1.0]])


class Matern52(Kernel):
    """Matérn kernel with ``nu = 5/2``: ``sigma**2 (1 + √5 d/l + 5 d²/(3 l²)) exp(-√5 d/l)``."""

    name = "matern52"
    #: dimension of the Markov state ``(f, f' / lambda, f'' / lambda**2)``, ``lambda = sqrt(5) / l``
    state_dim = 3

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        s = SQRT5 * scaled_distance(d, length)
        return (1.0 + s + s.square() / 3.0) * (-s).exp()

    def state_space(self, d: Tensor, length: Tensor) -> tuple[Tensor, Tensor]:
        """Transitions `... x 3 x 3` over steps `d` [m] and stationary covariance `3 x 3` of the
        scaled state ``(f, f' / lambda, f'' / lambda**2)`` at unit ``sigma_a``."""
        s = SQRT5 * scaled_distance(d, length)
        h = 0.5 * s.square()
        rows = [
            [1.0 + s + h, s + 2.0 * h, h],
            [-h, 1.0 + s - 2.0 * h, s - h],
            [h - s, 2.0 * h - 3.0 * s, 1.0 - 2.0 * s + h],
        ]
        third = 1.0 / 3.0
        return _state_space(rows, (-s).exp(), [[1.0, 0.0, -third], [0.0, third, 0.0], [-third, 0.0, 1.0]])


class SquaredExponential(Kernel):
    """Squared exponential kernel ``sigma**2 exp(-(d/l)²)``, without GPyTorch's factor 1/2."""

    name = "squared_exponential"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        return (-scaled_distance(d, length).square()).exp()

    #: ``exp(-(d/l)²) = exp(-d² / (2 s²))`` with spread ``s = l / sqrt(2)``: the reduced-rank
    #: form along a line (:mod:`torchshm.likelihood.hilbert`) sizes its basis in spreads
    gaussian_spread = 1.0 / math.sqrt(2.0)

    def spectral_density(self, omega: Tensor, length: Tensor) -> Tensor:
        """1-D spectral density of the correlation, ``sqrt(pi) l exp(-(omega l)² / 4)`` [m],
        at angular frequencies ``omega`` [rad/m] (``∫ S dω / 2π = 1``); broadcasts."""
        return math.sqrt(math.pi) * length * (-(omega * length).square() / 4.0).exp()
