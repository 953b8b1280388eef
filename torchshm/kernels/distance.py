"""Distances between positions along a line or coordinates of a field (the kernels' argument)."""

from __future__ import annotations

import torch
from torch import Tensor

__all__ = ["distances"]


def distances(x1: Tensor, x2: Tensor, l1: bool = False) -> Tensor:
    """Distances `n x m` [m] between positions `x1` and `x2`.

    Args:
        x1: `n` positions along a line, or `n x d` coordinates [m].
        x2: `m` positions, or `m x d` coordinates [m] (the same form as ``x1``).
        l1: coordinates' L1 (Manhattan) distance ``sum_k |x1_ik - x2_jk|`` instead of the
            Euclidean one (kernels of one correlation per direction).

    Returns:
        ``|x1_i - x2_j|`` for positions, the Euclidean distance ``||x1_i - x2_j||`` for
        coordinates (summed coordinate by coordinate, so the temporary is `n x m`, never
        `n x m x d`; the square root is taken where the distance is positive, so gradients with
        respect to the coordinates stay finite at coinciding points).

    Raises:
        ValueError: if ``x1`` and ``x2`` are not both `(n,)` or both `(n, d)` with the same `d`.
    """
    if x1.ndim == 1 and x2.ndim == 1:
        return (x1.unsqueeze(-1) - x2.unsqueeze(-2)).abs()
    if x1.ndim != 2 or x2.ndim != 2 or x1.shape[1] != x2.shape[1]:
        raise ValueError(
            f"kernel positions must be (n,) and (m,) or (n, d) and (m, d) coordinates, "
            f"got x1 {tuple(x1.shape)} and x2 {tuple(x2.shape)}"
        )
    square = x1.new_zeros(x1.shape[0], x2.shape[0])
    for k in range(x1.shape[1]):
        step = x1[:, k, None] - x2[None, :, k]
        square = square + (step.abs() if l1 else step.square())
    if l1:
        return square
    positive = square > 0
    return torch.where(positive, torch.where(positive, square, 1.0).sqrt(), 0.0)
