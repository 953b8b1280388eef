"""Priors of the physical and statistical parameters (paper, Tables 2 and 4)."""

from __future__ import annotations

from torchshm.priors.base import PLAUSIBLE_QUANTILES, Prior
from torchshm.priors.distributions import Gamma, Normal, Uniform

__all__ = ["PLAUSIBLE_QUANTILES", "Gamma", "Normal", "Prior", "Uniform"]
