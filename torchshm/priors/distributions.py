"""The priors of the paper's Table 2: uniform, gamma (rate parametrisation) and normal."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import torch
from torch import Tensor

from torchshm.priors.base import Bounds, Prior, bounds_pair, finite, positive

if TYPE_CHECKING:
    from scipy import stats


class Uniform(Prior):
    """Uniform prior on ``[a, b]``; its hard bounds are ``(a, b)``.

    Args:
        a: lower end.
        b: upper end, > ``a``.
        plausible: plausible bounds; ``None`` means the central 68.27 %.
    """

    def __init__(self, a: float, b: float, plausible: Bounds | None = None) -> None:
        self.a, self.b = bounds_pair("Uniform(a, b)", (a, b))
        super().__init__(None, plausible)

    def _support(self) -> Bounds:
        return (self.a, self.b)

    def _scipy(self) -> stats.rv_continuous:
        from scipy import stats

        return stats.uniform(self.a, self.b - self.a)

    def _log_density(self, x: Tensor) -> Tensor:
        return torch.full_like(x, -math.log(self.b - self.a))

    def __repr__(self) -> str:
        return f"Uniform({self.a:g}, {self.b:g})"


class Gamma(Prior):
    """Gamma prior with shape ``alpha`` and rate ``beta`` (mean ``alpha / beta``).

    With hard bounds the density is truncated to them and renormalised.

    Args:
        alpha: shape, > 0.
        beta: rate (inverse scale), > 0.
        bounds: hard bounds inside ``[0, inf)``; ``None`` means ``(0, inf)``.
        plausible: plausible bounds; ``None`` means the central 68.27 % of the truncated density.
    """

    def __init__(
        self,
        alpha: float,
        beta: float,
        bounds: Bounds | None = None,
        plausible: Bounds | None = None,
    ) -> None:
        self.alpha = positive("Gamma alpha", alpha)
        self.beta = positive("Gamma beta (rate)", beta)
        super().__init__(bounds, plausible)

    def _support(self) -> Bounds:
        return (0.0, math.inf)

    def _scipy(self) -> stats.rv_continuous:
        from scipy import stats

        return stats.gamma(self.alpha, scale=1.0 / self.beta)

    def _log_density(self, x: Tensor) -> Tensor:
        const = self.alpha * math.log(self.beta) - math.lgamma(self.alpha)
        return (
            const + torch.xlogy(torch.as_tensor(self.alpha - 1.0, dtype=x.dtype), x) - self.beta * x
        )

    def __repr__(self) -> str:
        return f"Gamma({self.alpha:g}, {self.beta:g})"


class Normal(Prior):
    """Normal prior with mean ``mean`` and standard deviation ``sd``.

    With hard bounds the density is truncated to them and renormalised.

    Args:
        mean: mean.
        sd: standard deviation, > 0.
        bounds: hard bounds; ``None`` means ``(-inf, inf)``.
        plausible: plausible bounds; ``None`` means the central 68.27 % of the truncated density
            (``mean -/+ sd`` without truncation).
    """

    def __init__(
        self, mean: float, sd: float, bounds: Bounds | None = None, plausible: Bounds | None = None
    ) -> None:
        self.mean = finite("Normal mean", mean)
        if not math.isfinite(self.mean):
            raise ValueError(f"Normal mean must be finite, got {self.mean}")
        self.sd = positive("Normal sd", sd)
        super().__init__(bounds, plausible)

    def _support(self) -> Bounds:
        return (-math.inf, math.inf)

    def _scipy(self) -> stats.rv_continuous:
        from scipy import stats

        return stats.norm(self.mean, self.sd)

    def _log_density(self, x: Tensor) -> Tensor:
        z = (x - self.mean) / self.sd
        return -0.5 * z.square() - math.log(self.sd) - 0.5 * math.log(2.0 * math.pi)

    def __repr__(self) -> str:
        return f"Normal({self.mean:g}, {self.sd:g})"
