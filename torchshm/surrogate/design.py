"""Designs of physical parameters at which a forward model is run to train a surrogate."""

from __future__ import annotations

import torch
from torch import Tensor

#: the paper's grid (Section 3.3): E_c [GPa] from 10 to 100 in 7 values
PAPER_E_C: tuple[float, float, int] = (10.0, 100.0, 7)
#: the paper's grid (Section 3.3): log10 K_r [log10 N·mm/rad] from 0 to 12 in 16 values
PAPER_LOG10_K_R: tuple[float, float, int] = (0.0, 12.0, 16)


def grid_design(*axes: Tensor) -> Tensor:
    """Full factorial grid of the given one-dimensional axes.

    Args:
        *axes: `P` tensors of values, one per parameter, in the forward model's order.

    Returns:
        `(n_1 * ... * n_P) x P` float64 design; the last parameter varies fastest.
    """
    mesh = torch.meshgrid(*[torch.as_tensor(a, dtype=torch.float64) for a in axes], indexing="ij")
    return torch.stack([m.reshape(-1) for m in mesh], dim=-1)


def paper_design() -> Tensor:
    """The paper's 7 x 16 training grid for bridge 705 (Section 3.3).

    Seven values of E_c linearly spaced from 10 to 100 GPa times sixteen values of
    log10 K_r linearly spaced from 0 to 12 (log10 N·mm/rad).

    Returns:
        `112 x 2` float64 design, columns (E_c [GPa], log10_K_r); log10_K_r varies fastest.
    """
    e_c = torch.linspace(*PAPER_E_C[:2], PAPER_E_C[2], dtype=torch.float64)
    log_k = torch.linspace(*PAPER_LOG10_K_R[:2], PAPER_LOG10_K_R[2], dtype=torch.float64)
    return grid_design(e_c, log_k)
