"""Look-up of the kernels by name."""

from __future__ import annotations

from torchshm.kernels.base import Kernel
from torchshm.kernels.stationary import (
    Exponential,
    Independent,
    Matern32,
    Matern52,
    SquaredExponential,
)

_CLASSES: dict[str, type[Kernel]] = {
    cls.name: cls for cls in (Independent, Exponential, Matern32, Matern52, SquaredExponential)
}

#: names of the kernels of the paper's Table 6, from rough to smooth discrepancy
KERNELS: tuple[str, ...] = tuple(_CLASSES)


def get_kernel(kernel: str | Kernel) -> Kernel:
    """The kernel called ``kernel`` (a :class:`Kernel` instance is returned as it is).

    Raises:
        ValueError: for an unknown name, listing the valid ones.
    """
    if isinstance(kernel, Kernel):
        return kernel
    try:
        return _CLASSES[kernel]()
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown kernel {kernel!r}; valid kernels are {', '.join(KERNELS)}"
        ) from None
