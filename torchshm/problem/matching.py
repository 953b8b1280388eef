"""Where the measured (line, x) lie among the forward model's (line, x).

A forward model gives strains at its own positions ``model.x`` (`n_model`, or `n_model x d`),
on one line or on several when it declares ``model.line`` (`n_model` labels beside ``x``).
:func:`match_measured` maps every measured position onto them, line by line:

- ``match="exact"`` (default): each measured position is one of the model's on the same line,
  within :data:`~torchshm.data.positions.POSITION_TOL` (the rule of
  :func:`~torchshm.data.positions.match_positions`);
- ``match="interpolate"``: 1-D positions are interpolated linearly between the two model
  positions around them on the same line (a real fibre's positions never coincide with element
  nodes); a position on a model position takes its value exactly. Nothing is extrapolated.

Either way, measured positions the model does not cover are named in one ``ValueError`` line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from torch import Tensor

from torchshm.arrays import as_numpy
from torchshm.data.positions import POSITION_TOL, match_positions

MATCHES = ("exact", "interpolate")


@dataclass(frozen=True)
class PositionMap:
    """Predictions at the measured positions: ``(1 - w) out[left] + w out[right]``.

    Attributes:
        left: `n` indices into the model's positions.
        right: `n` indices, or ``None`` for an exact match (then the prediction is ``out[left]``).
        weight: `n` weights in [0, 1] [-], or ``None`` for an exact match.
    """

    left: np.ndarray
    right: np.ndarray | None = None
    weight: np.ndarray | None = None

    @property
    def exact(self) -> bool:
        """Whether every measured position is one of the model's."""
        return self.weight is None

    def apply(self, outputs: Tensor) -> Tensor:
        """Strains `... x n` at the measured positions from model outputs `... x n_model`."""
        if self.weight is None:
            return outputs[..., self.left]
        w = outputs.new_tensor(self.weight)
        return outputs[..., self.left] * (1.0 - w) + outputs[..., self.right] * w


def match_measured(measurements: Any, model: Any, match: str = "exact") -> PositionMap:
    """The :class:`PositionMap` of the measured positions onto the model's, line by line.

    Args:
        measurements: a :class:`~torchshm.data.Measurements` (``x``, ``line_slices()``).
        model: a forward model with ``x`` and, for several lines, ``line``.
        match: ``"exact"`` or ``"interpolate"`` (1-D positions only).

    Raises:
        ValueError: in one line, for an unknown ``match``, lines that do not correspond, or
            measured positions outside the model (naming them and their line).
    """
    if match not in MATCHES:
        raise ValueError(f"Problem: match must be 'exact' or 'interpolate', got {match!r}")
    model_x = as_numpy(model.x).astype(np.float64)
    model_line = getattr(model, "line", None)
    labels = None
    if model_line is not None:
        labels = np.array([str(v) for v in np.asarray(model_line).ravel()], dtype=object)
    if labels is not None and labels.size != model_x.shape[0]:
        raise ValueError(f"Problem: model.line has {labels.size} labels for {model_x.shape[0]} positions")
    slices = measurements.line_slices()
    left, right, weight = [], [], []
    for label, part in slices.items():
        where = "" if label is None else f" on line {label!r}"
        candidates = _candidates(label, labels, list(slices), model_x.shape[0])
        x, xc = measurements.x[part], model_x[candidates]
        if match == "exact" or xc.shape[0] == 1:
            index = candidates[_exact(x, xc, where)]
            left.append(index), right.append(index), weight.append(np.zeros(index.size))
        else:
            a, b, w = _interpolate(x, xc, where)
            left.append(candidates[a]), right.append(candidates[b]), weight.append(w)
    if match == "exact":
        return PositionMap(np.concatenate(left))
    return PositionMap(np.concatenate(left), np.concatenate(right), np.concatenate(weight))


def _candidates(label: object, labels: np.ndarray | None, measured: list, n_model: int) -> np.ndarray:
    """Indices of the model positions on measured line ``label``."""
    if labels is None:
        if len(measured) > 1:
            raise ValueError(
                f"Problem: the measurements have {len(measured)} lines {measured} but the model declares "
                "no `line`; give the model a `line` attribute (one label per position of model.x)"
            )
        return np.arange(n_model)
    if label is None:
        distinct = list(dict.fromkeys(labels.tolist()))
        if len(distinct) > 1:
            raise ValueError(
                f"Problem: the model has lines {distinct} but the measurements name none; "
                "give the measurements line labels (Measurements(..., line=...))"
            )
        return np.arange(labels.size)
    found = np.flatnonzero(labels == str(label))
    if found.size == 0:
        known = list(dict.fromkeys(labels.tolist()))
        raise ValueError(f"Problem: measured line {label!r} is not among the model's lines {known}")
    return found


def _exact(x: np.ndarray, xc: np.ndarray, where: str) -> np.ndarray:
    """Indices into ``xc`` of the points ``x`` (1-D values or d-D points, within the tolerance)."""
    what = "position"
    if x.ndim == 1 and xc.ndim == 1:
        try:
            return match_positions(x, xc, what)
        except ValueError as err:
            if not where:
                raise
            raise ValueError(f"{err}{where}") from None
    if x.ndim != xc.ndim or x.shape[1] != xc.shape[1]:
        raise ValueError(f"Problem: measured {what}s have {x.shape[1:]} values per point, the model's {xc.shape[1:]}")
    from scipy.spatial import cKDTree

    distance, index = cKDTree(xc).query(x)  # n log n: a camera field of 1e5 points against 1e5
    index = np.asarray(index, dtype=np.int64)
    missing = distance > POSITION_TOL
    if missing.any():
        shown = ", ".join(str(tuple(float(v) for v in p)) for p in x[missing][:3])
        shown += ", ..." if missing.sum() > 3 else ""
        raise ValueError(f"measured {what}s not produced by the model (tolerance {POSITION_TOL:g} m): {shown}{where}")
    return index


def _interpolate(x: np.ndarray, xc: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Left and right indices into ``xc`` and weights of the 1-D positions ``x`` (no extrapolation)."""
    if x.ndim != 1 or xc.ndim != 1:
        raise ValueError("Problem: match='interpolate' needs 1-D positions along each line; use 'exact' for coordinates")
    order = np.argsort(xc, kind="stable")
    xs = xc[order]
    outside = (x < xs[0] - POSITION_TOL) | (x > xs[-1] + POSITION_TOL)
    if outside.any():
        shown = ", ".join(f"{v:g}" for v in x[outside][:5]) + (", ..." if outside.sum() > 5 else "")
        raise ValueError(
            f"Problem: {int(outside.sum())} measured position(s){where} fall outside the model "
            f"({xs[0]:g}..{xs[-1]:g} m; match='interpolate' does not extrapolate): {shown}"
        )
    j = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, xs.size - 2)
    step = xs[j + 1] - xs[j]
    w = np.clip((x - xs[j]) / np.where(step > 0, step, 1.0), 0.0, 1.0)
    on_left, on_right = np.abs(x - xs[j]) <= POSITION_TOL, np.abs(x - xs[j + 1]) <= POSITION_TOL
    a = np.where(on_right & ~on_left, j + 1, j)
    b = np.where(on_left | on_right, a, j + 1)
    w = np.where(on_left | on_right, 0.0, w)
    return order[a], order[b], w
