"""The base class of the priors: a scipy distribution truncated to hard bounds.

A prior has *hard bounds* ``(lo, hi)`` (closed; the density is 0 outside, and it is renormalised
to integrate to 1 on them) and *plausible bounds*, a narrower box where most of the mass is,
as PyVBMC asks for (paper, Table 4). Log densities are computed in torch so that they can be
differentiated; numpy in gives numpy out.
"""

from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from torchshm.arrays import as_float64

if TYPE_CHECKING:  # scipy.stats (1.5 s to import) is loaded by the first prior built
    from scipy import stats

#: quantiles of the default plausible bounds: the central 68.27 % (mean -/+ 1 sd of a normal)
PLAUSIBLE_QUANTILES = (0.15865525393145707, 0.8413447460685429)

Bounds = tuple[float, float]


class Prior(ABC):
    """A one-dimensional prior truncated to closed hard bounds.

    Args:
        bounds: hard bounds ``(lo, hi)``; ``None`` means the natural support.
        plausible: plausible bounds ``(lo, hi)`` inside the hard ones; ``None`` means the
            central 68.27 % of the (truncated) distribution, i.e. its 15.87 % and 84.13 %
            quantiles.

    Raises:
        ValueError: naming the problem, for inverted or non-numeric bounds, bounds outside the
            natural support, bounds holding no probability, or plausible bounds outside the hard
            ones.
    """

    def __init__(self, bounds: Bounds | None, plausible: Bounds | None) -> None:
        support = self._support()
        lo, hi = bounds_pair(f"{self!r} bounds", support if bounds is None else bounds)
        if lo < support[0] or hi > support[1]:
            raise ValueError(f"{self!r}: hard bounds {(lo, hi)} lie outside the support {support}")
        self.hard_bounds: Bounds = (lo, hi)
        self._cdf_lo, self._cdf_hi = (float(c) for c in self._scipy().cdf([lo, hi]))
        if not self._cdf_hi > self._cdf_lo:
            raise ValueError(f"{self!r}: hard bounds {(lo, hi)} hold no probability")
        self._log_mass = math.log(self._cdf_hi - self._cdf_lo)
        if plausible is None:
            plausible = tuple(float(q) for q in self.ppf(np.asarray(PLAUSIBLE_QUANTILES)))
        plo, phi = bounds_pair(f"{self!r} plausible bounds", plausible)
        if not (math.isfinite(plo) and math.isfinite(phi)):
            raise ValueError(f"{self!r}: plausible bounds {(plo, phi)} must be finite")
        if plo < lo or phi > hi:
            raise ValueError(
                f"{self!r}: plausible bounds {(plo, phi)} lie outside the hard bounds {(lo, hi)}"
            )
        self.plausible_bounds: Bounds = (plo, phi)

    @abstractmethod
    def _support(self) -> Bounds:
        """Natural support of the untruncated distribution."""

    @abstractmethod
    def _scipy(self) -> stats.rv_continuous:
        """The untruncated distribution as a frozen scipy distribution."""

    @abstractmethod
    def _log_density(self, x: Tensor) -> Tensor:
        """Untruncated log density at points ``x`` inside the hard bounds (torch)."""

    def log_prob(self, x: object) -> Tensor | np.ndarray:
        """Log density, renormalised on the hard bounds, -inf outside them (NaN included).

        Args:
            x: values, any shape, numpy or torch (torch keeps the autograd graph).

        Returns:
            Log densities of the same shape and kind as ``x`` (numpy for non-tensors).
        """
        t = as_float64(x)
        lo, hi = self.hard_bounds
        inside = (t >= lo) & (t <= hi)
        safe = torch.where(inside, t, self.plausible_bounds[0])
        value = torch.where(inside, self._log_density(safe) - self._log_mass, -torch.inf)
        return value if isinstance(x, Tensor) else value.numpy()

    def ppf(self, q: np.ndarray) -> np.ndarray:
        """Quantiles of the truncated distribution at probabilities ``q`` (numpy)."""
        q = np.asarray(q, dtype=np.float64)
        p = self._cdf_lo + q * (self._cdf_hi - self._cdf_lo)
        return np.clip(self._scipy().ppf(p), *self.hard_bounds)

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """``n`` independent draws (numpy `n`) by inverting the truncated distribution function."""
        return self.ppf(np.random.default_rng(rng).uniform(size=int(n)))


def bounds_pair(what: str, values: object) -> Bounds:
    """``values`` as an increasing pair of floats; ``ValueError`` naming ``what`` otherwise."""
    try:
        lo, hi = (float(v) for v in values)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a pair (lo, hi) of numbers, got {values!r}") from None
    if math.isnan(lo) or math.isnan(hi) or not lo < hi:
        raise ValueError(f"{what} must satisfy lo < hi, got {(lo, hi)}")
    return lo, hi


def finite(what: str, value: object) -> float:
    """``value`` as a finite float; ``TypeError`` (not a number) or ``ValueError`` (NaN, inf)
    naming ``what`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
        raise TypeError(f"{what} must be a number, got {value!r}")
    try:
        number = float(value)
    except ValueError:
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {number}")
    return number


def positive(what: str, value: object) -> float:
    """``value`` as a finite positive float; ``ValueError`` naming ``what`` otherwise."""
    value = finite(what, value)
    if value <= 0:
        raise ValueError(f"{what} must be finite and > 0, got {value}")
    return value
