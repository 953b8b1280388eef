"""Points on one regular grid.

:func:`lattice` tells whether `n x 2` coordinates lie on the nodes of one regular grid (a pitch
per direction; holes, masks and repeated points allowed: the grid is the points' bounding box),
as image-correlation (DIC) fields do, for :mod:`torchshm.likelihood.lattice`.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np
import torch

#: a coordinate within this share of the pitch of a node is on it (e.g. float32 coordinates)
SNAP = 1e-4
#: the most grid nodes per point: sparser points (a far outlier, a pitch that is not a common
#: divisor of the spacings) are not taken as a grid
MOST_NODES_PER_POINT = 10
#: a spacing below this share of the extent is rounding, not a pitch
ROUNDING = 1e-7


class Grid(NamedTuple):
    """Where `n` points sit on a regular grid of ``shape`` nodes.

    Attributes:
        ix, iy: `n` node indices along x and y (int64).
        shape: nodes along x and y, ``(Nx, Ny)``.
        pitch: node spacing along x and y [m] (1.0 along a direction with one node).
    """

    ix: np.ndarray
    iy: np.ndarray
    shape: tuple[int, int]
    pitch: tuple[float, float]

    @property
    def node(self) -> np.ndarray:
        """`n` node numbers ``ix * Ny + iy`` (row-major, as ``kron(Qx, Qy)`` numbers them)."""
        return self.ix * self.shape[1] + self.iy


def _axis(v: np.ndarray) -> tuple[np.ndarray, int, float] | None:
    """Node indices, node count and pitch of coordinates `n` along one direction, or None."""
    lo, span = float(v.min()), float(v.max() - v.min())
    if not span > 0:
        return np.zeros(v.shape, dtype=np.int64), 1, 1.0
    gaps = np.diff(np.unique(v))
    gaps = gaps[gaps > ROUNDING * span]
    for divisor in (1, 2, 3, 4):  # the pitch: the smallest spacing, or a small fraction of it
        steps = round(span / (float(gaps.min()) / divisor))
        if steps + 1 > MOST_NODES_PER_POINT * v.size:
            return None
        f = (v - lo) * (steps / span)
        index = np.rint(f)
        if float(np.abs(f - index).max()) <= SNAP:
            return index.astype(np.int64), steps + 1, span / steps
    return None


def lattice(x: object) -> Grid | None:
    """The regular grid that the points ``x`` `n x 2` [m] lie on, or None.

    A point is on a node when it is within :data:`SNAP` of the pitch of it in both directions;
    the grid spans the points' bounding box and may have at most :data:`MOST_NODES_PER_POINT`
    nodes per point.
    """
    if isinstance(x, torch.Tensor):  # the same tensor, unchanged, as last time: its grid again
        key = (x._version, tuple(x.shape), x.dtype)
        if _LAST is not None and _LAST[0]() is x and _LAST[1] == key:
            return _LAST[2]
        grid = _read(x.detach().cpu().numpy())
        _remember(x, key, grid)
        return grid
    return _read(np.asarray(x, dtype=np.float64))


#: the last tensor read (a weak reference), its version, shape and dtype, and its grid: one
#: evaluation asks for the grid of the same points several times (the form's choice, the
#: density, the draws), 0.06 s each at 10^6 points
_LAST: tuple | None = None


def _remember(x: torch.Tensor, key: tuple, grid: Grid | None) -> None:
    global _LAST
    _LAST = (weakref.ref(x), key, grid)


def _read(xs: np.ndarray) -> Grid | None:
    """:func:`lattice` of `n x 2` NumPy coordinates."""
    if xs.ndim != 2 or xs.shape[1] != 2 or xs.shape[0] == 0 or not np.isfinite(xs).all():
        return None
    along = [_axis(xs[:, k].astype(np.float64)) for k in range(2)]
    if along[0] is None or along[1] is None:
        return None
    (ix, nx, px), (iy, ny, py) = along
    if nx * ny > MOST_NODES_PER_POINT * xs.shape[0]:
        return None
    return Grid(ix, iy, (nx, ny), (px, py))
