"""Ordering and nearest previous neighbours of a point set, for the Vecchia form of Eq. (21).

The Vecchia approximation (:mod:`torchshm.likelihood.vecchia`) writes a density as a product of
conditionals ``p(y_i | y_N(i))``, ``N(i)`` the ``m`` nearest points *earlier in an ordering*.
Its accuracy depends on that ordering: a coarse-to-fine ("max-min") ordering, in which each
point is as far as possible from the points before it, lets the first points carry the long
range and the later ones the short range (Guinness, 2018, Technometrics 60(4)). Exact max-min
needs a sequential loop; here it is approximated by dyadic grids, which is vectorised:

- level 0 is the point nearest the centre of the bounding square; level ``k`` adds, in each of
  the ``2^k x 2^k`` cells (``2^k`` per axis in `d` dimensions), the not yet chosen point nearest
  the cell's centre; points left when every cell has at most one are last;
- within a level the order is random (a fixed seed, so the plan is reproducible).

The neighbours are found with ``scipy.spatial.cKDTree``, once per point set (:func:`plan` keeps
the last few plans): for ranks ``[a, 2a)`` a tree of the first ``2a`` points is queried for
``3m + 1`` nearest and those of a lower rank are kept (at least half of the tree's points are),
asking again with twice as many for the few points that got fewer than ``m``.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

#: memory [bytes] of the plans kept (one per point set and neighbour count: a field whose
#: load cases lose different subsets has one per load case); a plan of 10^6 points with m = 10
#: takes ~540 MB, of 10^5 points ~54 MB; the newest plan is always kept
PLANS_BYTES = 2**31
_PLANS: OrderedDict[tuple[bytes, int, bool], Plan] = OrderedDict()


@dataclass(frozen=True)
class Plan:
    """Order and conditioning sets of `n` points.

    Attributes:
        order: `n` indices: ``x[order]`` are the points in Vecchia order.
        blocks: `n x (m+1)` ranks (indices into ``x[order]``): row ``i`` holds the ``m`` nearest
            points before rank ``i`` (nearest first, ``-1`` where fewer exist), then ``i`` itself.
        lower: `n x M(M-1)/2` distances [m] within each block, ``M = m + 1`` (strictly lower
            triangle, :func:`lower_distances`), computed once: a call evaluates the kernel on them.
    """

    order: np.ndarray
    blocks: np.ndarray
    lower: np.ndarray

    @property
    def nbytes(self) -> int:
        """Memory of the plan's arrays [bytes]."""
        return self.order.nbytes + self.blocks.nbytes + self.lower.nbytes

    @property
    def neighbours(self) -> int:
        """``m``, the number of conditioning points per row."""
        return self.blocks.shape[1] - 1


def plan(x: np.ndarray, m: int, l1: bool = False) -> Plan:
    """The :class:`Plan` of `n x d` coordinates ``x`` [m] with ``m`` neighbours (cached); with
    ``l1`` the neighbours and block distances are L1 (Manhattan) ones (a kernel of one
    correlation per direction), else Euclidean."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    key = (hashlib.blake2b(x.tobytes() + str(x.shape).encode(), digest_size=16).digest(), int(m), bool(l1))
    found = _PLANS.get(key)
    if found is not None:
        _PLANS.move_to_end(key)
        return found
    order = coarse_to_fine(x)
    previous = previous_neighbours(x[order], m, l1)
    blocks = np.concatenate([previous, np.arange(x.shape[0])[:, None]], axis=1)
    made = Plan(order, blocks, lower_distances(x[order], blocks, l1=l1))
    _PLANS[key] = made
    while len(_PLANS) > 1 and sum(p.nbytes for p in _PLANS.values()) > PLANS_BYTES:
        _PLANS.popitem(last=False)
    return made


def coarse_to_fine(x: np.ndarray, seed: int | None = 0) -> np.ndarray:
    """Approximate max-min order `n` of `n x d` coordinates (dyadic grids, see the module)."""
    n, d = x.shape
    lo = x.min(axis=0)
    span = float((x.max(axis=0) - lo).max()) or 1.0
    unit = (x - lo) / span
    level = np.full(n, -1, dtype=np.int64)
    left = np.arange(n)
    k = 0
    while left.size and k < 60:
        cells = 2**k
        pos = unit[left] * cells
        cell = np.minimum(pos.astype(np.int64), cells - 1)
        gap = np.square(pos - cell - 0.5).sum(axis=1)
        flat = np.ravel_multi_index(cell.T, (cells,) * d) if cells ** d < 2**62 else left
        first = np.lexsort((gap, flat))
        _, pick = np.unique(flat[first], return_index=True)
        chosen = left[first[pick]]
        level[chosen] = k
        left = left[level[left] < 0]
        k += 1
    level[left] = k
    tie = np.arange(n) if seed is None else np.random.default_rng(seed).permutation(n)
    return np.lexsort((tie, level))


def lower_distances(x: np.ndarray, blocks: np.ndarray, chunk: int = 2**14, l1: bool = False) -> np.ndarray:
    """`n x M(M-1)/2` distances [m] (L1 with ``l1``, else Euclidean) within each block (`n x M`)
    of ordered coordinates ``x``, strictly lower triangle row by row
    (``numpy.tril_indices(M, -1)``); 0 for a missing slot."""
    n, size = blocks.shape
    rows, cols = np.tril_indices(size, -1)
    out = np.empty((n, rows.size))
    for start in range(0, n, chunk):
        part = blocks[start : start + chunk]
        pts = x[np.where(part >= 0, part, part[:, -1:])]
        gap = pts[:, rows] - pts[:, cols]
        out[start : start + chunk] = np.abs(gap).sum(-1) if l1 else np.sqrt(np.square(gap).sum(-1))
    return out


def previous_neighbours(x: np.ndarray, m: int, l1: bool = False) -> np.ndarray:
    """`n x m` ranks of the ``m`` nearest earlier points of ordered coordinates ``x`` (`n x d`),
    nearest first (L1 distance with ``l1``, else Euclidean), ``-1`` where a point has fewer than
    ``m`` before it."""
    n = x.shape[0]
    out = np.full((n, m), -1, dtype=np.int64)
    head = min(n, 4 * (m + 1))
    dist = cdist(x[:head], x[:head], "cityblock" if l1 else "euclidean")
    for i in range(1, head):
        near = np.argsort(dist[i, :i], kind="stable")[:m]
        out[i, : near.size] = near
    a = head
    while a < n:
        b = min(n, 2 * a)
        tree = cKDTree(x[:b])
        todo = np.arange(a, b)
        k = min(b, 3 * m + 1)
        while todo.size:
            _, idx = tree.query(x[todo], k=k, p=1 if l1 else 2)
            earlier = idx < todo[:, None]
            done = (earlier.sum(axis=1) >= m) | (k == b)
            first = np.argsort(~earlier[done], axis=1, kind="stable")[:, :m]
            ranks = np.take_along_axis(idx[done], first, axis=1)
            keep = np.take_along_axis(earlier[done], first, axis=1)
            out[todo[done]] = np.where(keep, ranks, -1)
            todo = todo[~done]
            k = min(b, 2 * k)
        a = b
    return out
