"""Designs of physical parameters at which a forward model is run to train a surrogate.

(Bridge 705's own grid, the paper's, is :func:`torchshm.casestudy.surrogate.paper_design`.)
"""

from __future__ import annotations

import torch
from torch import Tensor

def grid_design(*axes: Tensor) -> Tensor:
    """Full factorial grid of the given one-dimensional axes.

    Args:
        *axes: `P` tensors of values, one per parameter, in the forward model's order.

    Returns:
        `(n_1 * ... * n_P) x P` float64 design; the last parameter varies fastest.
    """
    mesh = torch.meshgrid(*[torch.as_tensor(a, dtype=torch.float64) for a in axes], indexing="ij")
    return torch.stack([m.reshape(-1) for m in mesh], dim=-1)

