"""Strain reading anomalies (SRAs) of distributed fibre-optic sensing, as a documented rule.

A reading is an anomaly when it stands out from its neighbours on both sides along the same
line, in the same reading, by more than a threshold:

    |ε_i - median(ε_{i-r}, ..., ε_{i-1})| > threshold  and  |ε_i - median(ε_{i+1}, ..., ε_{i+r})| > threshold

in µε, with NaN neighbours ignored; at a line end, or next to lost readings, the side with no
finite neighbour is left out, and a reading with no finite neighbour at all is never flagged.
It is a two-sided form of the local-median height test of fosanalysis' outlier-specific
correction with a fixed threshold: a real strain change (a step at a crack or a support)
agrees with the readings on one side and passes; a narrow spike (lost signal, a splice: up to
``(r - 1) // 2 + 1`` readings wide, 2 with the default ``r = 3``) disagrees with both sides and
is flagged. Choose the threshold well above the noise and below the spikes, e.g. 100-500 µε. Flagged readings become NaN,
i.e. dropouts of the mask (``missing="mask"``).
"""

from __future__ import annotations

import warnings

import numpy as np

from torchshm.data.measurements import Measurements


def anomaly_mask(values: np.ndarray, threshold: float, radius: int = 3) -> np.ndarray:
    """Where readings are anomalies, along the last axis.

    Args:
        values: `... x n` strains [µε] along one line (NaN allowed).
        threshold: largest plausible departure from the neighbours' median [µε], > 0.
        radius: neighbours on each side, >= 1.

    Returns:
        Boolean array of the shape of `values`, true at anomalies (never at NaN).
    """
    threshold, radius = float(threshold), int(radius)
    if not np.isfinite(threshold) or threshold <= 0:
        raise ValueError(f"anomaly threshold must be a positive number of µε, got {threshold}")
    if radius < 1:
        raise ValueError(f"anomaly radius must be >= 1, got {radius}")
    values = np.asarray(values, dtype=np.float64)
    n = values.shape[-1]
    pad = [(0, 0)] * (values.ndim - 1) + [(radius, radius)]
    padded = np.pad(values, pad, constant_values=np.nan)
    flagged = np.ones(values.shape, dtype=bool)
    seen = np.zeros(values.shape, dtype=bool)
    for shifts in (range(-radius, 0), range(1, radius + 1)):
        side = np.stack([padded[..., radius + k: radius + k + n] for k in shifts], axis=-1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN sides
            median = np.nanmedian(side, axis=-1)
        known = np.isfinite(median)
        with np.errstate(invalid="ignore"):
            flagged &= ~known | (np.abs(values - median) > threshold)
        seen |= known
    return flagged & seen & np.isfinite(values)


def flag_anomalies(m: Measurements, threshold: float, radius: int = 3) -> Measurements:
    """`m` with its anomalous readings (rule above, per line and load case) masked as dropouts.

    Args:
        m: measurements with 1-D positions.
        threshold: largest plausible departure from the neighbours' median [µε].
        radius: neighbours on each side along the line.

    Returns:
        A copy with ``missing="mask"``; :attr:`~Measurements.n_missing` counts the flagged ones.
    """
    if m.x.ndim != 1:
        raise ValueError("flag_anomalies: needs positions along lines (x is (n,)), not a field")
    y = m.y.copy()
    for s in m.line_slices().values():
        y[:, s][anomaly_mask(y[:, s], threshold, radius)] = np.nan
    line = None if m.line is None else m.line.tolist()
    return Measurements(m.x, y, m.loads, m.sigma_e, m.attrs, line=line, missing="mask")


__all__ = ["anomaly_mask", "flag_anomalies"]
