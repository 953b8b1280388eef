"""Where a posterior predictive is made: the problem's one view of the data, per sensor line.

The prediction reads the measured data the way the likelihood does (:class:`~torchshm.Problem`:
``positions``, ``blocks``, ``measurements.line_slices()``), so several fibres, interpolated
positions and `n x d` coordinates of a field need no second code path:

- ``positions="measured"``: the measured points (`n` positions along their lines or `n x d`
  coordinates), the model's outputs mapped onto them by the problem's own position map
  (exact or interpolated, :mod:`torchshm.problem.matching`);
- ``positions="model"``: every position of the forward model, with the model's ``line``.

Each line is one independent Gaussian of Eq. (21) per load case (the likelihood's blocks, with
every point of the line: a prediction has no dropout), with its line's noise and discrepancy
group (``discrepancy="per_line"``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from torchshm.arrays import as_numpy
from torchshm.problem.matching import PositionMap

if TYPE_CHECKING:
    from torchshm.problem import Problem


@dataclass(frozen=True)
class Part:
    """The points of one sensor line: one independent Gaussian of Eq. (21) per load case.

    Attributes:
        line: the line label (``None`` for one unnamed line).
        points: `n_b` indices into the prediction's points.
        group: column of the discrepancy parameters (σa, l) of the line.
        sigma_e: the line's measurement noise [µε].
    """

    line: object
    points: Tensor
    group: int
    sigma_e: float


@dataclass(frozen=True)
class PredictionView:
    """Points of a prediction, their line labels and how model outputs map onto them.

    Attributes:
        x: `n` positions along the lines [m] or `n x d` coordinates [m].
        line: `n` line labels (strings), or ``None`` for one unnamed line.
        positions: the map from model outputs (`... x n_model`) to the points.
        parts: the lines, in order.
    """

    x: Tensor
    line: np.ndarray | None
    positions: PositionMap
    parts: tuple[Part, ...]

    def apply(self, outputs: Tensor) -> Tensor:
        """Strains `... x n` at the points from model outputs `... x n_model` [µε]."""
        return self.positions.apply(outputs)


def prediction_view(problem: Problem, positions: str = "measured") -> PredictionView:
    """The :class:`PredictionView` of a problem at its measured or its model positions.

    Args:
        problem: the problem (``measurements``, ``positions``, ``blocks``, ``sigma_e``, ``model``).
        positions: ``"measured"`` or ``"model"``.

    Raises:
        ValueError: for another ``positions``, or, at the model's positions, a model line that
            was not measured while the discrepancy or the noise is per line (its parameters are
            unknown).
    """
    groups = {_key(b.line): int(b.group) for b in problem.blocks}
    if positions == "measured":
        meas = problem.measurements
        x = torch.as_tensor(np.asarray(meas.x, dtype=np.float64))
        parts = [(label, np.arange(part.start, part.stop)) for label, part in meas.line_slices().items()]
        line = None if meas.line is None else _labels(meas.line)
        return PredictionView(x, line, problem.positions, _parts(parts, groups, _noise(problem)))
    if positions != "model":
        raise ValueError(f"positions must be 'measured' or 'model', got {positions!r}")
    model = problem.model
    x = torch.as_tensor(as_numpy(model.x), dtype=torch.float64)
    model_line = getattr(model, "line", None)
    everything = PositionMap(np.arange(x.shape[0]))
    if model_line is None:
        return PredictionView(x, None, everything, _parts([(None, np.arange(x.shape[0]))], groups, _noise(problem)))
    line = _labels(model_line)
    order = list(dict.fromkeys(line.tolist()))
    if len(order) == 1 and len(groups) == 1:  # one line, measured unnamed or by its name
        parts = [(next(iter(groups)), np.arange(x.shape[0]))]
        return PredictionView(x, line, everything, _parts(parts, groups, _noise(problem), order[0]))
    parts = [(label, np.flatnonzero(line == label)) for label in order]
    return PredictionView(x, line, everything, _parts(parts, groups, _noise(problem)))


def _parts(parts: list[tuple[object, np.ndarray]], groups: Mapping[object, int],
           sigma_e: Mapping[object, float] | float, name: object = None) -> tuple[Part, ...]:
    """One :class:`Part` per line, with its discrepancy group and noise (one line's error)."""
    per_line_groups = len(set(groups.values())) > 1
    noise = {_key(k): float(v) for k, v in sigma_e.items()} if isinstance(sigma_e, Mapping) else None
    out = []
    for label, points in parts:
        key = _key(label)
        if (per_line_groups and key not in groups) or (noise is not None and key not in noise):
            raise ValueError(
                f"posterior predictive: model line {label!r} was not measured, so its discrepancy or "
                f"noise parameters are unknown (measured lines: {list(groups)}); use positions='measured'"
            )
        out.append(Part(label if name is None else name, torch.as_tensor(points, dtype=torch.long),
                        groups.get(key, 0), noise[key] if noise is not None else float(sigma_e)))
    return tuple(out)


def _key(label: object) -> object:
    """Line labels compared as text (a model's labels are strings, measured ones int or str)."""
    return None if label is None else str(label)


def _labels(line: object) -> np.ndarray:
    """`n` line labels as strings."""
    return np.array([str(v) for v in np.asarray(line).ravel()], dtype=object)


def _noise(problem: Problem) -> Mapping[object, float] | float:
    """The lines' noise sd [µε]; 1 when σe is inferred (each draw then scales it by its own)."""
    return 1.0 if hasattr(problem.sigma_e, "log_prob") else problem.sigma_e
