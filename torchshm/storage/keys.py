"""Canonical parameter vectors: the key under which an evaluation is stored.

Two parameter vectors that agree to 12 significant digits in every entry are the same
evaluation. The key is the text of the rounded values, so a store stays readable with any
SQLite browser and the same θp gives the same key on every machine.
"""

from __future__ import annotations

import numpy as np
from torch import Tensor

#: significant digits kept in a canonical parameter value
SIGNIFICANT_DIGITS = 12
_FORMAT = f"{{:.{SIGNIFICANT_DIGITS - 1}e}}"


def canonical_theta(theta_p: object) -> np.ndarray:
    """Float64 parameter vectors rounded to 12 significant digits.

    Args:
        theta_p: physical parameters, `N x P` or a single vector `P` (numpy, torch or nested
            lists), in the units of the forward model (for bridge 705: GPa, log10 N·mm/rad).

    Returns:
        `N x P` float64 array of the rounded values (-0.0 becomes 0.0).

    Raises:
        ValueError: if ``theta_p`` is empty in its last dimension, has more than two
            dimensions, or holds NaN or inf (the message names the first bad row).
    """
    if isinstance(theta_p, Tensor):
        theta_p = theta_p.detach().cpu().numpy()
    try:
        theta = np.array(theta_p, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"theta_p is not an array of numbers: {exc}") from None
    if theta.ndim == 1:
        theta = theta[None, :]
    if theta.ndim != 2:
        raise ValueError(f"theta_p must have shape (N, P) or (P,), got {theta.shape}")
    if theta.shape[1] == 0:
        raise ValueError(f"theta_p has no parameters (shape {theta.shape})")
    bad = ~np.isfinite(theta).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ValueError(f"theta_p row {row} is not finite: {theta[row].tolist()}")
    rounded = [float(_FORMAT.format(v)) + 0.0 for v in theta.ravel().tolist()]
    return np.array(rounded, dtype=np.float64).reshape(theta.shape)


def theta_key(theta: np.ndarray) -> str:
    """Text key of one canonical parameter vector `P`, e.g. ``"3.50000000000e+01,..."``."""
    return ",".join(_FORMAT.format(float(v) + 0.0) for v in theta)


def key_theta(key: str) -> np.ndarray:
    """Parameter vector `P` (float64) of a key made by :func:`theta_key`."""
    return np.array([float(v) for v in key.split(",")], dtype=np.float64)
