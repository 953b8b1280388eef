"""GPyTorch surrogates of forward models (paper, Section 3.3).

All `L x n` outputs of a forward model are modelled by GPs with one shared kernel over the
physical parameters θp, fitted by the exact marginal likelihood of all outputs at once; the
cost is one Cholesky factor of the `N x N` design covariance (see :mod:`.gp`). The fitted
:class:`Surrogate` is itself a forward model. Bridge 705's grid, boxes and shipped surrogate live
in :mod:`torchshm.physics.surrogate` (re-exported here).
"""

from __future__ import annotations

from typing import Any

from torchshm.surrogate.design import grid_design
from torchshm.surrogate.fit import fit_surrogate
from torchshm.surrogate.gp import SURROGATE_KERNELS, SharedKernelGP
from torchshm.surrogate.surrogate import Surrogate, load_surrogate
from torchshm.surrogate.transforms import ResponseTransform
from torchshm.surrogate.validation import SurrogateErrors, surrogate_errors, uniform_in_box

#: bridge 705's surrogate names, defined in :mod:`torchshm.physics.surrogate`
_BRIDGE = ("POSTERIOR_BOX", "PRIOR_BOX", "bridge705_surrogate", "paper_design", "shipped_path")

__all__ = [
    "POSTERIOR_BOX",
    "PRIOR_BOX",
    "SURROGATE_KERNELS",
    "ResponseTransform",
    "SharedKernelGP",
    "Surrogate",
    "SurrogateErrors",
    "bridge705_surrogate",
    "fit_surrogate",
    "grid_design",
    "load_surrogate",
    "paper_design",
    "shipped_path",
    "surrogate_errors",
    "uniform_in_box",
]


def __getattr__(name: str) -> Any:
    if name in _BRIDGE:
        from torchshm.physics import surrogate

        return getattr(surrogate, name)
    raise AttributeError(f"module 'torchshm.surrogate' has no attribute {name!r}")
