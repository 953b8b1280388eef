"""The identification :class:`Problem`: forward model, measurements, kernel and priors joined
into the log posterior that VBMC and emcee sample."""

from __future__ import annotations

from torchshm.problem.parameters import STATISTICAL, ParameterSplit, read_priors
from torchshm.problem.prior import JointPrior
from torchshm.problem.problem import Problem

__all__ = ["STATISTICAL", "JointPrior", "ParameterSplit", "Problem", "read_priors"]
