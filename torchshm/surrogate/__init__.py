"""GPyTorch surrogates of forward models (paper, Section 3.3).

All `L x n` outputs of a forward model are modelled by GPs with one shared kernel over the
physical parameters θp, fitted by the exact marginal likelihood of all outputs at once; the
cost is one Cholesky factor of the `N x N` design covariance (see :mod:`.gp`). The fitted
:class:`Surrogate` is itself a forward model. Bridge 705's grid, boxes and shipped surrogate belong
to the case study (:mod:`torchshm.casestudy.surrogate`).
"""

from __future__ import annotations

from torchshm.surrogate.design import grid_design
from torchshm.surrogate.fit import fit_surrogate
from torchshm.surrogate.gp import SURROGATE_KERNELS, SharedKernelGP
from torchshm.surrogate.surrogate import Surrogate, load_surrogate
from torchshm.surrogate.transforms import ResponseTransform
from torchshm.surrogate.validation import SurrogateErrors, surrogate_errors, uniform_in_box

__all__ = [
    "SURROGATE_KERNELS",
    "ResponseTransform",
    "SharedKernelGP",
    "Surrogate",
    "SurrogateErrors",
    "fit_surrogate",
    "grid_design",
    "load_surrogate",
    "surrogate_errors",
    "uniform_in_box",
]

