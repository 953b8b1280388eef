"""Default budgets of the emulator method: its initial design and its cap on model runs."""

from __future__ import annotations


def default_n_initial(n_phys: int, batch_size: int) -> int:
    """The default initial design for `P` physical parameters: the smallest multiple of
    ``batch_size`` of at least ``2 P + 1``."""
    return batch_size * max(1, -(-(2 * n_phys + 1) // batch_size))


def default_cap(dim: int, n_initial: int, batch_size: int) -> int:
    """The default cap on model runs: PyVBMC's budget, 50 (D + 2), for `D` inferred parameters
    (at least the initial design and two batches)."""
    return max(50 * (dim + 2), n_initial + 2 * batch_size)


__all__ = ["default_cap", "default_n_initial"]
