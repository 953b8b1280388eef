"""Default budgets of the emulator method (its initial design, its cap on model runs) and the
check of its integer options."""

from __future__ import annotations

from typing import Any

import numpy as np


def default_n_initial(n_phys: int, batch_size: int) -> int:
    """The default initial design for `P` physical parameters: the smallest multiple of
    ``batch_size`` of at least ``2 P + 1``."""
    return batch_size * max(1, -(-(2 * n_phys + 1) // batch_size))


def default_cap(dim: int, n_initial: int, batch_size: int) -> int:
    """The default cap on model runs: PyVBMC's budget, 50 (D + 2), for `D` inferred parameters
    (at least the initial design and two batches)."""
    return max(50 * (dim + 2), n_initial + 2 * batch_size)


def positive(name: str, value: Any, minimum: int = 1) -> int:
    """``value`` as an int, or a ValueError naming the emulator's option ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"method='emulator': {name} must be {what}, got {value!r}")
    return int(value)


__all__ = ["default_cap", "default_n_initial", "positive"]
