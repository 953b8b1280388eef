"""The noise of a strain field upscaled from independent element values, as a kernel.

``kernel=upscaled``: the covariance ``sigma_a**2 U Uᵀ`` (:func:`operator`: ``U``; the density:
:mod:`torchshm.likelihood.upscaled`):
independent values of sd ``sigma_a`` [µε] at the centres of square elements of side ``length``
[m], carried bilinearly to the points (an image correlation that writes its element strains on
a finer grid, e.g. muDIC's ``Fields(upscale=3)``). It is not a function of the distance (a point
between centres is an average of four elements, a centre is one element), so
:meth:`Upscaled.correlation` is not defined; the dense covariance (:meth:`Upscaled.__call__`,
for tests and small fields) and the sparse density through the elements (``method="auto"``, any
size) are exact. ``length`` is the correlation's element side, known from its settings: give it
a ``fixed`` prior.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import sparse
from torch import Tensor

from torchshm.kernels.base import Kernel, as_float64

#: a point within this share of an element side of a centre is on it (e.g. a float32 length)
SNAP = 1e-4


def cells(x: Tensor, length: Tensor | float) -> tuple[tuple[int, int], Tensor, Tensor]:
    """Each point's four element centres and bilinear weights on the whole element grid.

    Args:
        x: `n x 2` points [m]; length: the element side [m] (0-d; the weights follow it by
            autograd, the grid's shape and each point's cell do not).

    Returns:
        ``(shape, elements, weights)``: the `(Nx, Ny)` element centres from the points' smallest
        ``x`` and ``y`` (pitch ``length``), the `n x 4` element numbers ``i Ny + j`` (a clipped
        corner repeats one) and their `n x 4` weights (summing to 1).

    Raises:
        ValueError: for points that are not `n x 2` or a non-positive ``length``.
    """
    x = torch.as_tensor(x, dtype=torch.float64)
    length = torch.as_tensor(length, dtype=torch.float64)
    if x.ndim != 2 or x.shape[1] != 2:
        raise ValueError(f"upscaled field noise: points must be n x 2 coordinates, got {tuple(x.shape)}")
    if not float(length.detach()) > 0:
        raise ValueError(f"upscaled field noise: the element side (length) must be > 0 m, got {float(length.detach())}")
    f = (x - x.min(dim=0).values) / length  # element-centre grid coordinates
    shape = (f.detach().max(dim=0).values + SNAP).floor().long() + 1  # element centres each way
    base = torch.minimum((f.detach() + SNAP).floor().long(), (shape - 2).clamp_min(0))
    t = (f - base).clamp(0.0, 1.0)
    elements, weights = [], []
    for di, dj, w in ((0, 0, (1 - t[:, 0]) * (1 - t[:, 1])), (1, 0, t[:, 0] * (1 - t[:, 1])),
                      (0, 1, (1 - t[:, 0]) * t[:, 1]), (1, 1, t[:, 0] * t[:, 1])):
        ei = torch.clamp(base[:, 0] + di, max=int(shape[0]) - 1)
        ej = torch.clamp(base[:, 1] + dj, max=int(shape[1]) - 1)
        elements.append(ei * int(shape[1]) + ej)
        weights.append(w)
    return (int(shape[0]), int(shape[1])), torch.stack(elements, 1), torch.stack(weights, 1)


def operator(x: np.ndarray, length: float) -> sparse.csr_matrix:
    """``U`` `n x N`: bilinear weights from the element centres (pitch ``length`` [m]) to the
    points ``x`` `n x 2` [m] (:func:`cells`); elements that no point sees are left out.

    Raises:
        ValueError: for points that are not `n x 2` or a non-positive ``length``.
    """
    x = np.asarray(x)
    if x.ndim != 2 or x.shape[1] != 2:
        raise ValueError(f"upscaled field noise: points must be n x 2 coordinates, got {x.shape}")
    _, elements, weights = cells(torch.from_numpy(np.ascontiguousarray(x, dtype=np.float64)), float(length))
    rows_ = np.repeat(np.arange(x.shape[0]), 4)
    cols_, vals_ = elements.numpy().reshape(-1), weights.numpy().reshape(-1)
    keep = vals_ != 0.0
    # number the elements some point sees (at most 4 n), never the whole grid: an element side
    # far below the points' pitch would otherwise make a grid of ~(extent / length)² columns
    seen, column = np.unique(cols_[keep], return_inverse=True)
    return sparse.csr_matrix((vals_[keep], (rows_[keep], column.reshape(-1))),
                             shape=(x.shape[0], int(seen.size)))


class Upscaled(Kernel):
    """Independent element values upscaled bilinearly to `n x 2` points.

    ``sigma_a`` [µε] is the sd of one element's value; ``length`` [m] the element side. The
    points' first row and column must lie on element centres. :meth:`diag` gives
    ``sigma_a**2`` at every point, the variance at a centre (an upper bound between centres).
    """

    name = "upscaled"
    #: the likelihood's form for this kernel (:func:`torchshm.likelihood.marginal.choose_method`)
    form = "upscaled"

    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        raise NotImplementedError("kernel 'upscaled' is not a function of the distance")

    def __call__(self, x1: object, x2: object | None = None, *, sigma_a: object = 1.0,
                 length: object | None = None) -> Tensor:
        """Dense covariances ``sigma_a**2 U Uᵀ`` `... x n x n` [µε²] of the points ``x1`` `n x 2`.

        Raises:
            ValueError: for ``x2`` other than ``x1`` (the noise is defined on one field's points).
        """
        x1 = as_float64(x1)
        if x2 is not None and not torch.equal(as_float64(x2), x1):
            raise ValueError("kernel 'upscaled': covariances between two different point sets are not defined")
        sigma_a, length = self._parameters(sigma_a, length)
        n, out, shapes = x1.shape[0], [], {}
        for s, ell in zip(sigma_a.reshape(-1), length.reshape(-1).tolist()):
            if ell not in shapes:  # U Uᵀ once per element side
                u = torch.as_tensor(operator(x1.detach().cpu().numpy(), ell).toarray(), device=x1.device)
                shapes[ell] = u @ u.T
            out.append(s.square() * shapes[ell])  # differentiable in sigma_a
        return torch.stack(out).reshape(*sigma_a.shape, n, n) if out else x1.new_zeros(*sigma_a.shape, n, n)
