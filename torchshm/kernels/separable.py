"""A decoupled exponential kernel per direction, for image-correlation (DIC) fields.

``kernel=separable_exponential``: for `n x d` coordinates [m]::

    k(x, x') = sigma_a**2 exp(-|dx| / l - |dy| / l) = sigma_a**2 exp(-|dx| / l) exp(-|dy| / l)

the exponential of the L1 (Manhattan) distance, i.e. the product of one exponential (AR(1))
correlation per direction: the "decoupled kernel per direction" that Martínez et al. name for
2-D fields. Its correlation along a row or a column of a field is the ``exponential`` kernel's;
across the diagonal it decays faster than the Euclidean ``exponential`` (``|dx| + |dy| >=
||d||``). On `n` positions along a line it is ``exponential`` exactly, and the 1-D likelihood
takes the same exact O(n) state-space form (it inherits :meth:`Exponential.state_space`).

Because each direction is Markov, the field on a regular grid is a Gaussian Markov random field
whose precision is the Kronecker product of two tridiagonal matrices: on points of one regular
grid (holes allowed) the density of Eq. (21) is exact and sparse, ``method="lattice"``
(:mod:`torchshm.likelihood.lattice`), what ``method="auto"`` takes there. Off a grid, the dense
covariance (this class's :meth:`__call__`) is used, and from
:data:`~torchshm.likelihood.choice.VECCHIA_FROM` points the full-scale form (low rank +
Vecchia), with its neighbours and block distances in the L1 distance (:attr:`l1`).
"""

from __future__ import annotations

from torch import Tensor

from torchshm.kernels.distance import distances
from torchshm.kernels.stationary import Exponential


def manhattan(x1: Tensor, x2: Tensor) -> Tensor:
    """L1 distances `n x m` [m] between `n` (or `n x d`) and `m` (or `m x d`) points
    (:func:`~torchshm.kernels.base.distances` with ``l1=True``).

    Raises:
        ValueError: if ``x1`` and ``x2`` are not both `(n,)` or both `(n, d)` with the same `d`.
    """
    return distances(x1, x2, l1=True)


class SeparableExponential(Exponential):
    """``sigma_a**2 exp(-(|dx| + |dy|) / l)``: one exponential correlation per direction.

    ``sigma_a`` [µε] is the discrepancy's sd, ``length`` [m] its correlation length, the same in
    both directions. :meth:`correlation` is that of the distance it is given (``exp(-d / l)``);
    :meth:`__call__` gives it the L1 distance of coordinates (:attr:`l1`).
    """

    name = "separable_exponential"
    #: the likelihood's sparse form on a regular grid
    #: (:func:`torchshm.likelihood.choice.choose_method`, :mod:`torchshm.likelihood.lattice`)
    form = "lattice"
    #: coordinates enter through their L1 distance (:meth:`Kernel.__call__
    #: <torchshm.kernels.base.Kernel.__call__>`, :func:`manhattan`)
    l1 = True
