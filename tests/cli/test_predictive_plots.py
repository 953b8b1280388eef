"""The held-out figures: one panel per sensor line, and maps of a 2-D field."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from torchshm.cli import plots
from torchshm.data import Measurements
from torchshm.predictive import PredictiveResult


def prediction(x: np.ndarray, line: np.ndarray | None, loads: list[float]) -> PredictiveResult:
    n = x.shape[0]
    mean = torch.zeros(len(loads), n, dtype=torch.float64)
    samples = mean + torch.randn(50, len(loads), n, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    return PredictiveResult.from_draws(samples, torch.as_tensor(x), torch.tensor(loads), 0.95,
                                       np.zeros((50, 1)), ["a"], samples, False, 0.0, 5, line=line)


def test_one_panel_per_line(tmp_path: Path) -> None:
    x = np.tile(np.linspace(0.0, 1.0, 20), 2)
    line = np.array(["bottom"] * 20 + ["top"] * 20, dtype=object)
    y = np.random.default_rng(1).normal(size=(2, 40))
    y[0, 3] = np.nan  # a dropout
    data = Measurements(x, y, [1.0, 2.0], line=line, missing="mask")
    path = plots.predictive_plot(prediction(x, line, [1.0, 2.0]), data, tmp_path / "p.png")
    assert path.is_file() and path.stat().st_size > 10_000


def test_map_of_a_field_marks_the_points_outside(tmp_path: Path) -> None:
    gx, gy = np.meshgrid(np.arange(8) * 0.1, np.arange(5) * 0.1)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    y = np.zeros((1, 40))
    y[0, :4] = 10.0  # far outside the interval
    data = Measurements(xy, y, [0.5])
    path = plots.predictive_map(prediction(xy, None, [0.5]), data, 0.5, tmp_path / "m.png")
    assert path.is_file() and path.stat().st_size > 10_000
