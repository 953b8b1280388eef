"""Coverage, R², MSE and interval width against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.data import Measurements
from torchshm.predictive import PredictiveResult, coverage, mean_interval_width, mse, predictive_metrics, r2_score


def result() -> PredictiveResult:
    x = torch.tensor([0.0, 0.1, 0.2, 0.3])
    mean = torch.tensor([[1.0, 2.0, 3.0, 4.0], [0.0, 0.0, 0.0, 0.0]])
    samples = mean.expand(10, 2, 4).clone()
    pred = PredictiveResult.from_draws(samples, x, torch.tensor([20.0, 30.0]), 0.95,
                                       np.zeros((10, 1)), ["a"], samples, False, 0.0, 5)
    pred.lower, pred.upper = mean - 1.0, mean + torch.tensor([1.0, 1.0, 1.0, 3.0])
    return pred


def test_values() -> None:
    pred = result()
    y = np.array([[1.5, 2.0, 5.0, 4.0], [9.0, 9.0, 9.0, 9.0]])
    data = Measurements([0.0, 0.1, 0.2, 0.3], y, [20.0, 30.0])
    assert coverage(pred, data, [20.0]) == pytest.approx(0.75)
    assert mse(pred, data, [20.0]) == pytest.approx((0.25 + 4.0) / 4)
    yy = y[0]
    assert r2_score(pred, data, [20.0]) == pytest.approx(1 - 4.25 / np.sum((yy - yy.mean()) ** 2))
    assert mean_interval_width(pred, data, [20.0]) == pytest.approx(2.5)
    both = predictive_metrics(pred, data)
    assert both.coverage == pytest.approx(3 / 8) and both.n_points == 8


def test_shared_positions_only() -> None:
    pred = result()
    data = Measurements([0.1, 0.3, 0.5], [[2.0, 4.0, 7.0]], [20.0])
    metrics = predictive_metrics(pred, data)
    assert metrics.n_points == 2 and metrics.coverage == 1.0 and metrics.mse == 0.0  # load 30 unmeasured
    with pytest.raises(ValueError, match="share no position"):
        predictive_metrics(pred, Measurements([5.0], [[1.0]], [20.0]))
    with pytest.raises(ValueError, match="unknown load case"):
        predictive_metrics(pred, data, [30.0])
