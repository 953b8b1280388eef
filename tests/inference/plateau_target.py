"""A log density with a plateau the chain barely visits, for the final step's tests."""

from __future__ import annotations

import numpy as np
from scipy.stats import norm


def plateau(rows: np.ndarray) -> np.ndarray:
    """`B` log densities at rows `B x 2`: x standard normal; y 97 % in a bump of sd 0.3 at 0 and
    3 % flat over 2..8 (a saturating parameter's plateau)."""
    y = rows[:, 1]
    flat = np.where((y > 2.0) & (y < 8.0), np.log(0.03 / 6.0), -np.inf)
    return norm(0.0, 1.0).logpdf(rows[:, 0]) + np.logaddexp(np.log(0.97) + norm(0.0, 0.3).logpdf(y), flat)
