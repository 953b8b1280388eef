"""Scores of a posterior predictive against measurements (paper, Tables 10 and 13).

- coverage: share of measurements inside the equal-tailed interval;
- R²: ``1 - sum (y - mean)² / sum (y - ybar)²`` with the predictive mean;
- MSE: ``mean (y - mean)²`` [µε²];
- mean interval width: mean of ``upper - lower`` [µε].

All are pooled over the load cases and points that the prediction and the measurements share
(matched on the same sensor line, positions or coordinates within 1e-6 m), or given per load
case and line by :func:`metrics_table`; masked readings (dropouts) are not scored.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Iterable

import numpy as np

from torchshm.data.positions import match_on_lines, nearest_index
from torchshm.predictive.result import PredictiveResult


@dataclass(frozen=True)
class PredictiveMetrics:
    """Scores of a prediction (see the module docstring).

    Attributes:
        coverage: share in [0, 1] of measurements inside the interval.
        r2: coefficient of determination of the predictive mean.
        mse: mean squared error of the predictive mean [µε²].
        mean_width: mean interval width [µε].
        n_points: number of compared measurements.
    """

    coverage: float
    r2: float
    mse: float
    mean_width: float
    n_points: int

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def aligned(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None,
            line: object = None) -> tuple[np.ndarray, ...]:
    """Measurements and predictive summaries on shared load cases and points.

    Points are matched line by line (:func:`~torchshm.data.positions.match_on_lines`: same
    line label, position or coordinates within 1e-6 m).

    Args:
        pred: a posterior predictive result.
        measurements: a :class:`~torchshm.data.Measurements` (``x``, ``y``, ``loads``, ``line``).
        loads: load cases to compare; default the load cases of ``pred`` that are measured.
        line: compare the points of this line only (``None``: every line).

    Returns:
        ``(y, mean, lower, upper)``, each `L'' x n''` [µε] (``y`` NaN at dropouts).

    Raises:
        ValueError: when a load case is not measured or predicted, or no point is shared.
    """
    if loads is None:
        _, measured = nearest_index(pred.loads.numpy(), measurements.loads)
        loads = pred.loads.numpy()[measured].tolist()
        if not loads:
            raise ValueError("metrics: no load case of the prediction is measured")
    loads = np.atleast_1d(np.asarray(list(loads), dtype=np.float64))
    rows = [pred.select(v) for v in loads]
    y = measurements.select(loads).y
    labels = getattr(measurements, "line", None)
    match, found = match_on_lines(measurements.x, labels, pred.x.numpy(), pred.line)
    if line is not None and labels is not None:
        found &= np.array([str(v) for v in labels]) == str(line)
    shared_m = np.flatnonzero(found)
    if shared_m.size == 0:
        where = "" if line is None else f" on line {line!r}"
        raise ValueError(f"metrics: the prediction and the measurements share no position{where}")
    pick = lambda t: t.numpy()[rows][:, match[shared_m]]  # noqa: E731
    return y[:, shared_m], pick(pred.mean), pick(pred.lower), pick(pred.upper)


def _valid(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """The entries where the measurement (first array) is finite: dropouts are not scored."""
    keep = np.isfinite(arrays[0])
    return tuple(a[keep] for a in arrays)


def coverage(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Share of measurements inside the predictive interval (Table 10)."""
    return predictive_metrics(pred, measurements, loads).coverage


def r2_score(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Coefficient of determination of the predictive mean (Table 13)."""
    return predictive_metrics(pred, measurements, loads).r2


def mse(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Mean squared error of the predictive mean [µε²] (Table 13)."""
    return predictive_metrics(pred, measurements, loads).mse


def mean_interval_width(pred: PredictiveResult, measurements: Any | None = None,
                        loads: Iterable[float] | None = None) -> float:
    """Mean width of the predictive interval [µε] (Table 13), at the measured points if given."""
    if measurements is None:
        rows = [pred.select(v) for v in (pred.loads.numpy() if loads is None else loads)]
        return float(pred.width.numpy()[rows].mean())
    return predictive_metrics(pred, measurements, loads).mean_width


def predictive_metrics(pred: PredictiveResult, measurements: Any,
                       loads: Iterable[float] | None = None, line: object = None) -> PredictiveMetrics:
    """All scores of :class:`PredictiveMetrics` for the shared load cases and points (of one
    ``line`` when given); masked (NaN) readings are not scored."""
    y, mean, lower, upper = _valid(*aligned(pred, measurements, loads, line))
    resid = y - mean
    return PredictiveMetrics(
        coverage=float(np.mean((y >= lower) & (y <= upper))),
        r2=float(1.0 - np.sum(resid**2) / np.sum((y - y.mean()) ** 2)),
        mse=float(np.mean(resid**2)),
        mean_width=float(np.mean(upper - lower)),
        n_points=int(y.size),
    )


def metrics_table(pred: PredictiveResult, measurements: Any,
                  loads: Iterable[float] | None = None) -> list[dict[str, Any]]:
    """Scores per load case and sensor line: one row per (load, line), then per load case one
    row ``line="all"`` pooling its lines (a single row ``"all"`` for one unnamed line).

    Returns:
        Rows ``{"load", "line", "coverage", "r2", "mse", "mean_width", "n_points"}``.
    """
    if loads is None:
        _, measured = nearest_index(pred.loads.numpy(), measurements.loads)
        loads = pred.loads.numpy()[measured].tolist()
    lines = [v for v in getattr(measurements, "lines", (None,)) if v is not None]
    rows: list[dict[str, Any]] = []
    for load in loads:
        for label in lines if len(lines) > 1 else []:
            m = predictive_metrics(pred, measurements, [float(load)], label)
            rows.append({"load": float(load), "line": str(label), **m.as_dict()})
        m = predictive_metrics(pred, measurements, [float(load)])
        rows.append({"load": float(load), "line": "all", **m.as_dict()})
    return rows
