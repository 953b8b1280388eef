"""Lost readings of a real campaign, simulated on synthetic data: :func:`with_dropouts`.

Distributed fibres lose readings: single ones at random (strain reading anomalies) and whole
stretches at once (lost signal at a crack or a splice). :func:`with_dropouts` masks both in a
copy of a :class:`~torchshm.data.Measurements` (``missing="mask"``), so that identification
from a campaign with dropouts can be tested against the truth.
"""

from __future__ import annotations

import numpy as np

from torchshm.data.measurements import Measurements


def with_dropouts(
    m: Measurements, fraction: float = 0.05, gap: float = 0.4, seed: int = 0
) -> Measurements:
    """A copy of ``m`` with readings lost as in a real campaign, masked (``missing="mask"``).

    In each load case a share ``fraction`` of the readings is lost at random (without
    replacement), and one stretch of ``gap`` m of one line, chosen at random, is lost at once
    (a signal loss at a crack or splice): positions in ``[start, start + gap)``. Drawn from
    ``numpy.random.default_rng(seed)``, load case by load case.

    Args:
        m: 1-D measurements (one or several lines).
        fraction: share of the readings lost at random per load case, in [0, 1).
        gap: length of the stretch lost per load case [m], >= 0 (0: none).
        seed: seed of the draws.

    Raises:
        ValueError: for a fraction or gap out of range, or coordinates (`n x d`).
    """
    if not 0.0 <= fraction < 1.0 or not gap >= 0.0 or m.x.ndim != 1:
        raise ValueError(f"with_dropouts: need 0 <= fraction < 1, gap >= 0 and 1-D x, got {fraction}, {gap}")
    rng = np.random.default_rng(seed)
    y, parts = m.y.copy(), list(m.line_slices().values())
    for row in y:
        row[rng.choice(m.n, size=int(round(fraction * m.n)), replace=False)] = np.nan
        if gap > 0.0:
            part = parts[rng.integers(len(parts))]
            x = m.x[part]
            start = rng.uniform(x[0], max(x[0], x[-1] - gap))
            row[part][(x >= start) & (x < start + gap)] = np.nan
    return Measurements(m.x, y, m.loads, m.sigma_e, m.attrs, line=m.line, missing="mask")
