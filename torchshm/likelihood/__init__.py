"""The likelihood of Eq. (21) and the identification :class:`Problem`."""

from __future__ import annotations

from torchshm.likelihood.gaussian import log_likelihood
from torchshm.likelihood.problem import Problem

__all__ = ["Problem", "log_likelihood"]
