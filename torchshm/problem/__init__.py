"""The identification :class:`Problem`: forward model, measurements, kernel and priors joined
into the log posterior that VBMC and emcee sample."""

from __future__ import annotations

from torchshm.problem.parameters import STATISTICAL, read_priors
from torchshm.problem.problem import Problem

__all__ = ["STATISTICAL", "Problem", "read_priors"]
