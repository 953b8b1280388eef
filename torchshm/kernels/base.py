"""The base class of the distance kernels of the model discrepancy (paper, Table 6).

A kernel here is stateless: its parameters, the scale ``sigma_a`` [µε] and the correlation
length ``length`` [m], are passed at each call, so that one call builds the covariance matrices
of a whole batch of parameter vectors (shape ``...``) at once.

Positions are `n` arc lengths along a line (distance ``|x - x'|``) or `n x d` coordinates of a
field such as an image-correlation grid (Euclidean distance ``||x - x'||``), see
:func:`distances`. The 1-D case is computed exactly as before coordinates were accepted.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import torch
from torch import Tensor

from torchshm.arrays import as_float64
from torchshm.kernels.distance import distances
from torchshm.kernels.table import distance_table, gather

__all__ = ["MIN_LENGTH", "REGISTRY", "Kernel", "as_float64", "distances", "n_points", "scaled_distance"]

#: name -> kernel class, in the order the classes were defined (filled by ``Kernel`` itself)
REGISTRY: dict[str, type[Kernel]] = {}

#: Smallest correlation length [m] used in a computation. Shorter lengths are raised to it: the
#: correlation of two distinct points more than ~1e-6 m apart is then exactly 0 in float64, as it
#: is for any shorter length, and ``d / l`` and its gradient stay finite at ``l = 0``.
MIN_LENGTH = 1e-9


def n_points(x: Tensor) -> int:
    """Number of points of `n` positions or `n x d` coordinates."""
    return int(x.shape[0]) if x.ndim == 2 else int(x.shape[-1])


class Kernel(ABC):
    """A stationary kernel ``k(d) = sigma_a**2 * rho(d; length)`` of the distance ``d``.

    Subclasses set :attr:`name` and implement :meth:`correlation`. A subclass that sets
    :attr:`name` in its own body registers itself under that name (:data:`REGISTRY`): it is
    then found by :func:`torchshm.kernels.get_kernel`, listed by
    :func:`torchshm.kernels.kernel_names` and offered as ``kernel=<name>`` by
    ``torchshm-identify``. Adding a kernel is this one class (and its test)::

        class Cauchy(Kernel):
            name = "cauchy"

            def correlation(self, d, length):
                return 1.0 / (1.0 + scaled_distance(d, length).square())
    """

    #: name used in configuration files and in :data:`torchshm.kernels.KERNELS`
    name: ClassVar[str]
    #: whether the kernel has a correlation length parameter
    has_length: ClassVar[bool] = True
    #: whether every covariance matrix of distinct points is diagonal
    is_diagonal: ClassVar[bool] = False
    #: whether coordinates enter through their L1 distance instead of the Euclidean one
    l1: ClassVar[bool] = False
    #: for a correlation ``exp(-d² / (2 s²))``, ``s / length``; such a kernel also has
    #: ``spectral_density(omega, length)`` (:mod:`torchshm.likelihood.hilbert`); None otherwise
    gaussian_spread: ClassVar[float | None] = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Register a subclass that names itself (``name`` set in its own class body)."""
        super().__init_subclass__(**kwargs)
        name = cls.__dict__.get("name")
        if name is None:
            return
        if not isinstance(name, str) or not name.isidentifier():
            raise TypeError(f"kernel {cls.__qualname__}: name must be an identifier, got {name!r}")
        known = REGISTRY.get(name)
        if known is not None and known.__qualname__ != cls.__qualname__:
            raise TypeError(
                f"kernel {cls.__qualname__}: name {name!r} is already taken by {known.__qualname__}"
            )
        REGISTRY[name] = cls

    @abstractmethod
    def correlation(self, d: Tensor, length: Tensor | None) -> Tensor:
        """Correlation ``rho`` of points at distances `d` [m].

        Args:
            d: distances `... x n x m` [m], >= 0.
            length: correlation lengths [m] broadcastable to `d` (e.g. `... x 1 x 1`); ``None``
                for a kernel without length.

        Returns:
            `... x n x m` correlations, equal to 1 where ``d == 0``.
        """

    def __call__(
        self,
        x1: object,
        x2: object | None = None,
        *,
        sigma_a: object = 1.0,
        length: object | None = None,
    ) -> Tensor:
        """Covariance matrices ``K[..., i, j] = k(d(x1_i, x2_j))`` (:func:`distances`; with
        ``x2=None``, the correlation of each distinct distance of ``x1`` gathered into the
        matrix, :mod:`torchshm.kernels.table`).

        Args:
            x1: `n` positions [m], or `n x d` coordinates [m] (Euclidean distance).
            x2: `m` positions or `m x d` coordinates [m]; ``None`` means ``x1``.
            sigma_a: scale [µε], shape `...` (a scalar for one matrix).
            length: correlation length [m], broadcastable with ``sigma_a``; ignored (may be
                ``None``) when :attr:`has_length` is false.

        Returns:
            `... x n x m` covariances [µε²], float64.
        """
        x1 = as_float64(x1)
        sigma_a, length = self._parameters(sigma_a, length)
        if x2 is None and (table := distance_table(x1, l1=self.l1)) is not None:
            values, index = table  # one correlation per distinct distance (kernels/table.py)
            ell = None if length is None else length[..., None]
            return gather(sigma_a[..., None].square() * self.correlation(values, ell), index)
        x2 = x1 if x2 is None else as_float64(x2)
        d = distances(x1, x2, l1=self.l1)
        ell = None if length is None else length[..., None, None]
        return sigma_a[..., None, None].square() * self.correlation(d, ell)

    def diag(self, x: object, *, sigma_a: object = 1.0) -> Tensor:
        """Diagonal `... x n` of ``self(x, sigma_a=sigma_a, length=...)`` [µε²] (`x`: `n` or `n x d`)."""
        x = as_float64(x)
        sigma_a = as_float64(sigma_a)
        return sigma_a[..., None].square().expand(*sigma_a.shape, n_points(x))

    def _parameters(self, sigma_a: object, length: object | None) -> tuple[Tensor, Tensor | None]:
        """``sigma_a`` and ``length`` as float64 tensors broadcast to a common shape."""
        sigma_a = as_float64(sigma_a)
        if not self.has_length:
            return sigma_a, None
        if length is None:
            raise ValueError(f"kernel {self.name!r} needs a correlation length, got None")
        length = as_float64(length)
        shape = torch.broadcast_shapes(sigma_a.shape, length.shape)
        return sigma_a.expand(shape), length.expand(shape)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def scaled_distance(d: Tensor, length: Tensor) -> Tensor:
    """``d / length`` with the length raised to at least :data:`MIN_LENGTH` (finite gradients)."""
    return d / length.clamp_min(MIN_LENGTH)
