"""The canonical key of a physical parameter vector (12 significant digits), shared with the
evaluation store, under which model outputs are cached."""

from __future__ import annotations

import numpy as np

#: significant digits of a canonical parameter value
SIGNIFICANT_DIGITS = 12


def canonical_key(theta_p: np.ndarray) -> tuple[float, ...]:
    """Cache key of one physical parameter vector `P`: values rounded to 12 significant digits."""
    fmt = f"{{:.{SIGNIFICANT_DIGITS - 1}e}}"
    return tuple(float(fmt.format(float(v))) + 0.0 for v in theta_p)
