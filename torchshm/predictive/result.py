"""The result of a posterior predictive computation, and its file format."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from torchshm.predictive.draws import equal_tailed


@dataclass
class PredictiveResult:
    """Posterior predictive strains at `L'` load cases and `n_x` points.

    The points are those of the problem's data view: positions along one or several sensor
    lines (``x`` `n_x`, ``line`` `n_x` labels) or coordinates of a field (``x`` `n_x x d`).

    Attributes:
        mean: `L' x n_x` predictive mean [µε].
        lower, upper: `L' x n_x` bounds of the equal-tailed interval [µε].
        samples: `n x L' x n_x` predictive draws [µε]: float64, or float32 for
            ``keep="summary"`` (:func:`~torchshm.predictive.posterior_predictive`).
        x: `n_x` positions along their line [m], or `n_x x d` coordinates [m].
        loads: `L'` load cases (front-axle positions [m]).
        level: probability content of the interval (0.95).
        theta: `n x D` posterior draws used, columns named by :attr:`names`.
        names: `D` parameter names.
        eta: `n x L' x n_x` float64 model responses at the draws (emulated or exact) [µε],
            or ``None`` for ``keep="summary"``.
        surrogate_variance_used: whether the emulator's variance was added to ``eta``.
        max_surrogate_sd: largest emulator standard deviation at the draws [µε] (0 when exact).
        n_training: stored model evaluations the emulator was trained on (0 when exact).
        line: `n_x` line labels (strings) of the points, or ``None`` for one unnamed line.
    """

    mean: Tensor
    lower: Tensor
    upper: Tensor
    samples: Tensor
    x: Tensor
    loads: Tensor
    level: float
    theta: np.ndarray
    names: list[str]
    eta: Tensor | None
    surrogate_variance_used: bool
    max_surrogate_sd: float
    n_training: int
    line: np.ndarray | None = None

    @classmethod
    def from_draws(
        cls, samples: Tensor, x: Tensor, loads: Tensor, level: float, theta: np.ndarray,
        names: list[str], eta: Tensor | None, used: bool, max_sd: float, n_training: int,
        line: np.ndarray | None = None,
    ) -> PredictiveResult:
        """Summarise `n x L' x n_x` draws into mean and equal-tailed bounds (by chunks of
        points, :func:`~torchshm.predictive.draws.equal_tailed`)."""
        mean, lower, upper = equal_tailed(samples, level)
        return cls(mean, lower, upper, samples, x, loads, level, theta, names, eta, used,
                   max_sd, n_training, line)

    @property
    def lines(self) -> tuple:
        """Line labels in order of first appearance (``(None,)`` for one unnamed line)."""
        return (None,) if self.line is None else tuple(dict.fromkeys(self.line.tolist()))

    def points_of(self, line: object) -> np.ndarray:
        """Indices of the points on ``line`` (every point for ``None``)."""
        if line is None or self.line is None:
            return np.arange(self.x.shape[0])
        found = np.flatnonzero(self.line == str(line))
        if found.size == 0:
            raise ValueError(f"line {line!r} is not in this prediction (lines {list(self.lines)})")
        return found

    @property
    def width(self) -> Tensor:
        """`L' x n_x` interval widths [µε]."""
        return self.upper - self.lower

    def select(self, load: float) -> int:
        """Row of the load case ``load`` [m] in :attr:`loads`."""
        hits = torch.nonzero((self.loads - float(load)).abs() <= 1e-6).flatten()
        if hits.numel() == 0:
            raise ValueError(f"load case {load:g} is not in this prediction ({self.loads.tolist()})")
        return int(hits[0])

    def to_xarray(self, include_samples: bool = False):  # -> xarray.Dataset
        """The summary (and optionally the draws) as an :class:`xarray.Dataset`.

        Variables ``mean``, ``lower``, ``upper`` on ``(load, point)`` (``samples`` on
        ``(draw, load, point)``); coordinates ``load`` and, on ``point``, ``x`` (positions
        along the line) or ``x``, ``y`` [, ``z``] (coordinates of a field), and ``line`` when
        the points carry line labels.
        """
        import xarray as xr

        data = {k: (("load", "point"), getattr(self, k).numpy()) for k in ("mean", "lower", "upper")}
        if include_samples:
            data["samples"] = (("draw", "load", "point"), self.samples.numpy())
        attrs = {
            "level": self.level,
            "surrogate_variance_used": int(self.surrogate_variance_used),
            "max_surrogate_sd": self.max_surrogate_sd,
            "n_training": self.n_training,
            "n_draws": int(self.samples.shape[0]),
        }
        x = self.x.numpy()
        coords = {"load": self.loads.numpy()}
        if x.ndim == 1:
            coords["x"] = ("point", x)
        else:
            coords.update({axis: ("point", x[:, i]) for i, axis in enumerate("xyz"[: x.shape[1]])})
        if self.line is not None:
            coords["line"] = ("point", np.asarray(self.line, dtype=str))
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def save(self, path: str | Path, include_samples: bool = False) -> Path:
        """Write :meth:`to_xarray` to a netCDF file; returns the path."""
        path = Path(path)
        self.to_xarray(include_samples).to_netcdf(path, engine="h5netcdf")
        return path

    def __repr__(self) -> str:
        loads = ", ".join(f"{v:g}" for v in self.loads.tolist())
        return (
            f"PredictiveResult(loads [{loads}], {self.x.shape[0]} points"
            f"{'' if self.line is None else f' on {len(self.lines)} line(s)'}, "
            f"{self.samples.shape[0]} draws, surrogate variance "
            f"{'used' if self.surrogate_variance_used else 'not used'}, "
            f"max surrogate sd {self.max_surrogate_sd:.2e} µε)"
        )
