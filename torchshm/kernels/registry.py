"""Look-up of the kernels by name.

Every :class:`~torchshm.kernels.base.Kernel` subclass that sets ``name`` registers itself in
:data:`~torchshm.kernels.base.REGISTRY` when its class body runs; nothing here lists classes.
"""

from __future__ import annotations

from torchshm.kernels import stationary  # noqa: F401  (defines, and so registers, Table 6)
from torchshm.kernels.base import REGISTRY, Kernel

#: names of the kernels of the paper's Table 6, from rough to smooth discrepancy (the kernels
#: registered when torchshm is imported; :func:`kernel_names` also lists later ones)
KERNELS: tuple[str, ...] = tuple(REGISTRY)


def kernel_names() -> tuple[str, ...]:
    """Names of every registered kernel, in the order they were defined."""
    return tuple(REGISTRY)


def get_kernel(kernel: str | Kernel) -> Kernel:
    """The kernel called ``kernel`` (a :class:`Kernel` instance is returned as it is).

    Raises:
        ValueError: for an unknown name, listing the valid ones.
    """
    if isinstance(kernel, Kernel):
        return kernel
    try:
        return REGISTRY[kernel]()
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown kernel {kernel!r}; valid kernels are {', '.join(kernel_names())}"
        ) from None


__all__ = ["KERNELS", "get_kernel", "kernel_names"]
