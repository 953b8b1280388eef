"""Scores of a posterior predictive against measurements (paper, Tables 10 and 13).

- coverage: share of measurements inside the equal-tailed interval;
- R²: ``1 - sum (y - mean)² / sum (y - ybar)²`` with the predictive mean;
- MSE: ``mean (y - mean)²`` [µε²];
- mean interval width: mean of ``upper - lower`` [µε].

All are pooled over the load cases and positions that the prediction and the measurements
share (positions matched within 1e-6 m).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Iterable

import numpy as np

from torchshm.data.positions import nearest_index
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


def aligned(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> tuple[np.ndarray, ...]:
    """Measurements and predictive summaries on shared load cases and positions.

    Args:
        pred: a posterior predictive result.
        measurements: a :class:`~torchshm.data.Measurements` (``x``, ``y``, ``loads``).
        loads: load cases to compare; default the load cases of ``pred`` that are measured.

    Returns:
        ``(y, mean, lower, upper)``, each `L'' x n''` [µε].

    Raises:
        ValueError: when a load case is not measured or predicted, or no position is shared.
    """
    if loads is None:
        _, measured = nearest_index(pred.loads.numpy(), measurements.loads)
        loads = pred.loads.numpy()[measured].tolist()
        if not loads:
            raise ValueError("metrics: no load case of the prediction is measured")
    loads = np.atleast_1d(np.asarray(list(loads), dtype=np.float64))
    rows = [pred.select(v) for v in loads]
    y = measurements.select(loads).y
    px, mx = pred.x.numpy(), np.asarray(measurements.x, dtype=np.float64)
    match, found = nearest_index(px, mx)
    shared_p, shared_m = np.flatnonzero(found), match[found]
    if shared_p.size == 0:
        raise ValueError("metrics: the prediction and the measurements share no position")
    pick = lambda t: t.numpy()[rows][:, shared_p]  # noqa: E731
    return y[:, shared_m], pick(pred.mean), pick(pred.lower), pick(pred.upper)


def coverage(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Share of measurements inside the predictive interval (Table 10)."""
    y, _, lower, upper = aligned(pred, measurements, loads)
    return float(np.mean((y >= lower) & (y <= upper)))


def r2_score(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Coefficient of determination of the predictive mean (Table 13)."""
    y, mean, _, _ = aligned(pred, measurements, loads)
    return float(1.0 - np.sum((y - mean) ** 2) / np.sum((y - y.mean()) ** 2))


def mse(pred: PredictiveResult, measurements: Any, loads: Iterable[float] | None = None) -> float:
    """Mean squared error of the predictive mean [µε²] (Table 13)."""
    y, mean, _, _ = aligned(pred, measurements, loads)
    return float(np.mean((y - mean) ** 2))


def mean_interval_width(pred: PredictiveResult, measurements: Any | None = None,
                        loads: Iterable[float] | None = None) -> float:
    """Mean width of the predictive interval [µε] (Table 13), at the measured points if given."""
    if measurements is None:
        rows = [pred.select(v) for v in (pred.loads.numpy() if loads is None else loads)]
        return float(pred.width.numpy()[rows].mean())
    _, _, lower, upper = aligned(pred, measurements, loads)
    return float(np.mean(upper - lower))


def predictive_metrics(pred: PredictiveResult, measurements: Any,
                       loads: Iterable[float] | None = None) -> PredictiveMetrics:
    """All scores of :class:`PredictiveMetrics` for the shared load cases and positions."""
    y, mean, lower, upper = aligned(pred, measurements, loads)
    valid = np.isfinite(y)
    if not valid.all():  # masked (dropped) readings are not scored
        y, mean, lower, upper = y[valid], mean[valid], lower[valid], upper[valid]
    resid = y - mean
    return PredictiveMetrics(
        coverage=float(np.mean((y >= lower) & (y <= upper))),
        r2=float(1.0 - np.sum(resid**2) / np.sum((y - y.mean()) ** 2)),
        mse=float(np.mean(resid**2)),
        mean_width=float(np.mean(upper - lower)),
        n_points=int(y.size),
    )
