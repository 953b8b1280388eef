"""The plate seen by a camera: the example's forward model on the image-correlation grid.

:class:`CameraPlate` is the finite-difference plate of ``examples/plate_dic`` (Kirchhoff,
rotational-spring edges at x = 0 and x = a, patch loads), evaluated at every interior node of
its grid and carried onto the points of the correlation grid by bilinear interpolation (a
sparse `n x N` matrix, so 1e5 points cost one sparse product per parameter vector). The points
are the regular grid ``x0 + i dx``, ``y0 + j dy`` [m], sorted by x then y, the order in which
:func:`torchshm.data.dic.read_dic` returns a field. Two physical parameters, as the plate's:
``E`` [GPa] and ``log10_k`` [log10 N·m/rad/m].
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import sparse
from torch import Tensor

from examples.plate_dic.plate import PlateDIC
from examples.plate_dic_camera.measure import Correlation


def grid_points(x0: float, y0: float, dx: float, dy: float, nx: int, ny: int) -> np.ndarray:
    """`(nx ny) x 2` points [m] of the regular grid, sorted by x then y, rounded to 1e-9 m."""
    gx, gy = np.meshgrid(x0 + dx * np.arange(nx), y0 + dy * np.arange(ny), indexing="ij")
    points = np.column_stack([gx.reshape(-1), gy.reshape(-1)])
    return np.round(points / 1e-9) * 1e-9


class CameraPlate:
    """Forward model ``model(theta_p `... x 2`) -> eps_xx `... x L x n` [µε]`` at the grid points.

    Args:
        grid: the correlation grid ``{x0, y0, dx, dy, nx, ny}`` [m]; every point must lie within
            the plate's interior nodes (at least ``cell`` from each edge).
        element: ``None``: the finite-difference strains, bilinear between nodes; or the
            correlation's element side [m]: the strains the correlation measures
            (:class:`examples.plate_dic_camera.measure.Correlation`).
        **plate: keyword arguments of :class:`PlateDIC` (size, thickness, poisson, cell, patch,
            force, loads); its ``pitch`` is set to ``cell`` (every interior node).
    """

    names = PlateDIC.names
    units = PlateDIC.units

    def __init__(self, grid: dict, element: float | None = None, **plate: object) -> None:
        plate = {k: v for k, v in plate.items() if k != "pitch"}
        cell = float(plate.get("cell", 0.0625))  # type: ignore[arg-type]
        self.plate = PlateDIC(pitch=cell, **plate)  # type: ignore[arg-type]
        self.loads = self.plate.loads
        self.x = torch.as_tensor(grid_points(**grid), dtype=torch.float64)
        self._interp = _bilinear(self.plate.x.numpy(), self.x.numpy(), cell)
        self.measure = None
        if element is not None:
            h, (a, b) = self.plate.h, self.plate.size
            self._shape = (round(a / h) - 1, round(b / h) - 1)  # interior nodes each way
            xs, ys = h * np.arange(self._shape[0] + 2), h * np.arange(self._shape[1] + 2)
            self.measure = Correlation(xs, ys, grid, float(element), self.plate.t)
        self.identity = f"CameraPlate-{self.plate.identity}-{tuple(sorted(grid.items()))}-{element}"

    def __call__(self, theta_p: object) -> Tensor:
        """Strains ``eps_xx`` `... x L x n` [µε] for ``(E, log10_k)`` `... x 2`."""
        if self.measure is not None:
            theta = torch.as_tensor(theta_p, dtype=torch.float64)
            flat = theta.reshape(-1, 2)
            w = self.plate.deflections(flat[:, 0], 10.0 ** flat[:, 1]).numpy()  # B x L x N
            full = np.zeros((*w.shape[:2], self._shape[0] + 2, self._shape[1] + 2))
            full[..., 1:-1, 1:-1] = w.reshape(*w.shape[:2], *self._shape)
            out = torch.from_numpy(self.measure(full))
            return out.reshape(*theta.shape[:-1], len(self.loads), self.x.shape[0])
        nodes = self.plate(theta_p)  # ... x L x N
        flat = nodes.reshape(-1, nodes.shape[-1]).numpy()
        out = np.asarray(self._interp @ flat.T).T  # (... L) x n
        return torch.from_numpy(out).reshape(*nodes.shape[:-1], self.x.shape[0])

    def __repr__(self) -> str:
        return f"CameraPlate(n={self.x.shape[0]}, loads={len(self.loads)})"


def _bilinear(nodes: np.ndarray, points: np.ndarray, cell: float) -> sparse.csr_matrix:
    """`n x N` bilinear interpolation from the grid ``nodes`` `N x 2` (pitch ``cell``) to ``points``."""
    lo = nodes.min(axis=0)
    shape = np.round((nodes.max(axis=0) - lo) / cell).astype(int) + 1
    index = np.full(shape, -1)
    ij = np.round((nodes - lo) / cell).astype(int)
    index[ij[:, 0], ij[:, 1]] = np.arange(nodes.shape[0])
    f = (points - lo) / cell
    if (f < -1e-9).any() or (f > shape - 1 + 1e-9).any():
        raise ValueError(f"CameraPlate: grid points outside the plate's interior nodes {lo} .. {nodes.max(axis=0)} m")
    base = np.minimum(np.floor(f + 1e-9).astype(int), shape - 2)
    t = f - base
    rows, cols, vals = [], [], []
    for di, dj, w in ((0, 0, (1 - t[:, 0]) * (1 - t[:, 1])), (1, 0, t[:, 0] * (1 - t[:, 1])),
                      (0, 1, (1 - t[:, 0]) * t[:, 1]), (1, 1, t[:, 0] * t[:, 1])):
        rows.append(np.arange(points.shape[0]))
        cols.append(index[base[:, 0] + di, base[:, 1] + dj])
        vals.append(w)
    return sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(points.shape[0], nodes.shape[0]))
