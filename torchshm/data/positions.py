"""The one rule that matches positions: load cases and sensor positions [m] within 1 µm.

Every place that looks a measured load case or sensor position up among a model's (the
:class:`~torchshm.problem.Problem`, the strain files of an external model, the predictive
selection, :meth:`~torchshm.data.Measurements.load_index`) goes through :func:`nearest_index`,
so they agree on what "the same position" means.
"""

from __future__ import annotations

import numpy as np

#: tolerance [m] for matching load-case positions and sensor positions
POSITION_TOL = 1e-6


def nearest_index(wanted: object, available: object) -> tuple[np.ndarray, np.ndarray]:
    """Index of the nearest available value for each wanted one, and whether it is a match.

    Args:
        wanted: `k` values [m] (any array-like; flattened).
        available: `m >= 1` values [m] (any array-like; flattened), in any order.

    Returns:
        ``(index, found)``: `k` integer indices into ``available`` and `k` booleans, true where
        the nearest value lies within :data:`POSITION_TOL` (NaN never matches).

    Raises:
        ValueError: if ``available`` is empty.
    """
    wanted = np.asarray(wanted, dtype=np.float64).ravel()
    available = np.asarray(available, dtype=np.float64).ravel()
    if available.size == 0:
        raise ValueError("nothing to match against: no available positions")
    order = np.argsort(available, kind="stable")
    ordered = available[order]
    right = np.searchsorted(ordered, wanted).clip(0, ordered.size - 1)
    left = (right - 1).clip(0, ordered.size - 1)
    nearest = np.where(
        np.abs(ordered[left] - wanted) <= np.abs(ordered[right] - wanted), left, right
    )
    found = np.abs(ordered[nearest] - wanted) <= POSITION_TOL
    return order[nearest], found


def match_positions(wanted: object, available: object, what: str) -> np.ndarray:
    """Indices into ``available`` (the model's values) of the values ``wanted``.

    Args:
        wanted: `k` values (measured load cases or positions [m]).
        available: `m` values the model produces.
        what: their name in error messages (``"load case"``, ``"position"``).

    Returns:
        `k` integer indices.

    Raises:
        ValueError: naming the values the model does not produce.
    """
    available = np.asarray(available, dtype=np.float64).ravel()
    if available.size == 0:
        raise ValueError(f"the model produces no {what}s")
    wanted = np.asarray(wanted, dtype=np.float64).ravel()
    index, found = nearest_index(wanted, available)
    missing = wanted[~found]
    if missing.size:
        shown = ", ".join(f"{v:g}" for v in missing[:5]) + (", ..." if missing.size > 5 else "")
        raise ValueError(
            f"measured {what}s not produced by the model (tolerance {POSITION_TOL:g} m): "
            f"{shown}; the model has {available.size} {what}s from {available.min():g} "
            f"to {available.max():g}"
        )
    return index


def nearest_point(wanted: object, available: object) -> tuple[np.ndarray, np.ndarray]:
    """:func:`nearest_index` for points: `k` values or `k x d` coordinates [m] among `m` ones.

    Returns:
        ``(index, found)`` as :func:`nearest_index`; for coordinates the nearest point in the
        Euclidean distance, found within :data:`POSITION_TOL`.
    """
    wanted, available = np.asarray(wanted, dtype=np.float64), np.asarray(available, dtype=np.float64)
    if wanted.ndim <= 1 and available.ndim <= 1:
        return nearest_index(wanted, available)
    if wanted.ndim != 2 or available.ndim != 2 or wanted.shape[1] != available.shape[1]:
        raise ValueError(f"points of shape {wanted.shape} and {available.shape} cannot be matched")
    if available.shape[0] == 0:
        raise ValueError("nothing to match against: no available positions")
    from scipy.spatial import cKDTree

    distance, index = cKDTree(available).query(wanted)
    return np.asarray(index, dtype=np.int64), distance <= POSITION_TOL


def match_on_lines(
    wanted: object, wanted_line: object, available: object, available_line: object
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`nearest_point` line by line: a point matches only a point on the same line.

    Args:
        wanted, available: `k` and `m` positions [m] or `k x d`, `m x d` coordinates [m].
        wanted_line, available_line: `k` and `m` line labels (compared as text), or ``None``
            (one unnamed line: matched against every available point).

    Returns:
        ``(index, found)``: `k` indices into ``available`` and `k` booleans.
    """
    wanted, available = np.asarray(wanted, dtype=np.float64), np.asarray(available, dtype=np.float64)
    if wanted_line is None or available_line is None:
        return nearest_point(wanted, available)
    mine = np.array([str(v) for v in np.asarray(wanted_line).ravel()])
    theirs = np.array([str(v) for v in np.asarray(available_line).ravel()])
    index, found = np.zeros(mine.size, dtype=np.int64), np.zeros(mine.size, dtype=bool)
    for label in dict.fromkeys(mine.tolist()):
        rows, candidates = np.flatnonzero(mine == label), np.flatnonzero(theirs == label)
        if candidates.size:
            i, ok = nearest_point(wanted[rows], available[candidates])
            index[rows], found[rows] = candidates[i], ok
    return index, found
