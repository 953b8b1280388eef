"""The rank and neighbours of the full-scale form, chosen per call from what the field needs.

The full-scale form (:mod:`torchshm.likelihood.fullscale`) costs O(n (m² r + r²)) per call, so a
fixed rank of 512 and 30 neighbours pays for the hardest case everywhere. What the field needs
depends on the kernel's length against the pivots' spacing and on the discrepancy's variance
against the diagonal ``D = sigma_m² eta² + sigma_e²`` of Eq. (21) (the nugget):

- **pivots** by a greedy pivoted Cholesky of the correlation among the first coarse-to-fine
  points (:data:`CANDIDATES` per pivot), stopped by its residual: once the largest conditional
  variance left, ``sigma_a² (1 - F Fᵀ)_ii``, is at most :data:`PIVOT_REL` times the smallest
  nugget, the residual ``K - F Fᵀ`` is a small perturbation of ``D`` and few neighbours
  represent it (``resolved``: long, smooth lengths; tens to hundreds of pivots);
- otherwise the rank runs to its cap (memory, :func:`~torchshm.likelihood.fullscale.rank_for`)
  and the residual is left to the most neighbours (:data:`NEIGHBOURS_MAX`), unless the pivots
  took off less than :data:`USEFUL` of the candidates' variance (lengths of a few pitches,
  shorter than the pivots' spacing): then they are dropped (plain Vecchia with the most
  neighbours), since they would cost time and buy nothing.

The choice is made without gradient at the batch's shortest length and largest ``sigma_a``
(the hardest of the batch); the factor itself stays differentiable. It changes with the
parameters only in steps (a pivot more or less, 10 or 30 neighbours), which moves the value by
at most the approximation's error (measured, ``docs/likelihood.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.kernels.base import distances

#: the pivots stop once ``sigma_a² x`` the largest conditional correlation-variance left is at
#: most this share of the smallest nugget (``docs/likelihood.md``, measured)
PIVOT_REL = 1e-3
#: a pivot whose conditional correlation-variance is below this ends the pivots in any case
#: (the rest add nothing numerically)
PIVOT_TOL = 1e-9
#: the largest rank (further capped by memory, :func:`~torchshm.likelihood.fullscale.rank_for`)
RANK_MAX = 512
#: pivots are chosen among the first ``CANDIDATES x`` cap points of the coarse-to-fine order
CANDIDATES = 4
#: neighbours when the pivots resolve the kernel to :data:`PIVOT_REL` of the nugget
NEIGHBOURS_RESOLVED = 10
#: neighbours otherwise (capped by :func:`~torchshm.likelihood.fullscale.neighbours_for`)
NEIGHBOURS_MAX = 30
#: pivots that take off less than this share of the mean variance of the other candidates
#: are dropped
USEFUL = 0.25


@dataclass(frozen=True)
class Choice:
    """What one call of the full-scale form uses.

    Attributes:
        pivots: `r` indices into the coarse-to-fine ordered points (may be empty).
        neighbours: ``m``, Vecchia neighbours per point (before the memory cap).
        resolved: whether the pivots met :data:`PIVOT_REL` (else the rank reached its cap).
        left: the candidates' largest conditional correlation-variance after the pivots.
    """

    pivots: Tensor
    neighbours: int
    resolved: bool
    left: float


def choose(xo: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, noise: Tensor, cap: int) -> Choice:
    """Pivots and neighbours for coarse-to-fine ordered coordinates ``xo`` (`n x d` [m]).

    Args:
        xo: `n x d` coordinates [m] in the plan's order.
        kern: the kernel; sigma_a: `B` scales [µε]; length: `B` lengths [m].
        noise: `B x L x n` diagonal of Eq. (21) [µε²].
        cap: the largest rank (memory).
    """
    with torch.no_grad():
        floor = float(noise.min()) / float(sigma_a.max().square().clamp_min(1e-300))
        tol = max(PIVOT_TOL, PIVOT_REL * floor)
        if cap == 0:
            return Choice(xo.new_zeros(0, dtype=torch.int64), NEIGHBOURS_MAX, False, 1.0)
        cand = xo[: CANDIDATES * cap]
        corr = kern.correlation(distances(cand, cand, l1=kern.l1), length.min().reshape(1, 1))
        pivots, left = greedy_pivots(corr, cap, tol)
    worst = float(left.max())
    if worst <= tol:
        return Choice(pivots, NEIGHBOURS_RESOLVED, True, worst)
    others = torch.ones_like(left, dtype=torch.bool)
    others[pivots] = False
    if float(left[others].mean()) > 1.0 - USEFUL:  # the candidates that are not pivots
        return Choice(pivots[:0], NEIGHBOURS_MAX, False, 1.0)
    return Choice(pivots, NEIGHBOURS_MAX, False, worst)


def greedy_pivots(corr: Tensor, rank: int, tol: float = PIVOT_TOL) -> tuple[Tensor, Tensor]:
    """A greedy pivoted Cholesky of the `c x c` correlation ``corr``: at most ``rank`` pivot
    indices, each the candidate worst predicted by the earlier ones, until the largest
    conditional variance left is at most ``tol``; and that variance `c` after them."""
    c = corr.shape[0]
    left = corr.diagonal().clone()
    cols = corr.new_zeros(c, min(rank, c))
    chosen = []
    for k in range(min(rank, c)):
        p = int(torch.argmax(left))
        if float(left[p]) <= tol:
            break
        col = (corr[:, p] - cols[:, :k] @ cols[p, :k]) / left[p].sqrt()
        cols[:, k] = col
        left = (left - col.square()).clamp_min(0.0)
        left[p] = 0.0
        chosen.append(p)
    return torch.as_tensor(chosen, dtype=torch.int64, device=corr.device), left
