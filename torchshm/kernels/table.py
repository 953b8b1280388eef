"""The distinct distances of a fixed set of points, kept between calls.

A dense covariance of `n` points has `n²` entries but, on a fibre or a camera grid, few
distinct distances: 931 of 123,201 at the bridge's 351 positions (0.1 m pitch), 110 of 36,864
at the plate's 192 grid points. A kernel then evaluates its correlation once per distinct
distance and gathers the `n x n` matrix from that table (:meth:`Kernel.__call__
<torchshm.kernels.base.Kernel.__call__>`): the values are those of the direct computation (the
same floating-point distances, deduplicated exactly), at the cost of one gather per parameter
vector instead of several elementwise passes over `n²` entries.

The table is kept per points tensor (the same object with the same in-place version, on its
device) for the few point sets a run uses; it is not used for points that require a gradient,
for more than :data:`MAX_POINTS` points, or where the distinct distances exceed a quarter of the
entries (scattered points), where the direct computation is as fast.
"""

from __future__ import annotations

import math
import weakref

import torch
from torch import Tensor

from torchshm.kernels.distance import distances

__all__ = ["MAX_POINTS", "distance_table", "gather"]

#: largest number of points given a table (its index is `n x n` int64, 32 MB at 2,048 points;
#: above it the factorisation, `n³`, outweighs building the matrix)
MAX_POINTS = 2048
#: point sets remembered at once
KEPT = 8

_TABLES: dict[tuple[int, bool], tuple[weakref.ref, int, tuple[Tensor, Tensor] | None]] = {}


def distance_table(x: Tensor, l1: bool = False) -> tuple[Tensor, Tensor] | None:
    """Distinct distances ``values`` `U` [m] and ``index`` `n x n` (``values[index]`` is the
    distance matrix of ``x`` with itself), or ``None`` where a table does not pay.

    Args:
        x: `n` positions or `n x d` coordinates [m] (the key of the kept table).
        l1: L1 distances of coordinates (:func:`~torchshm.kernels.distance.distances`).
    """
    n = int(x.shape[0])
    if x.requires_grad or n > MAX_POINTS or n < 2:
        return None
    key = (id(x), l1)
    kept = _TABLES.get(key)
    if kept is not None and kept[0]() is x and kept[1] == x._version:
        return kept[2]
    values, index = torch.unique(distances(x, x, l1=l1), return_inverse=True)
    table = (values, index) if 4 * values.numel() <= n * n else None
    _TABLES[key] = (weakref.ref(x), x._version, table)
    while len(_TABLES) > KEPT:  # the oldest made go first
        _TABLES.pop(next(iter(_TABLES)), None)
    return table


def gather(values: Tensor, index: Tensor) -> Tensor:
    """``values[..., index]``: `... x U` values on a `n x n` table index -> `... x n x n`
    (one vector: ``take``; several: rows of the transposed values, the faster gathers)."""
    *lead, size = values.shape
    if math.prod(lead) == 1:
        return values.reshape(-1).take(index).reshape(*lead, *index.shape)
    rows = values.reshape(-1, size).T.contiguous().index_select(0, index.reshape(-1))  # n² x B
    return rows.T.reshape(*lead, *index.shape)
