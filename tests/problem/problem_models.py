"""Small hand-made forward models for the Problem tests (no finite element model)."""

from __future__ import annotations

import numpy as np
import torch

from torchshm.casestudy import paper_priors
from torchshm.data import Measurements

PAPER_LOADS = (10.5, 16.9, 24.5, 32.2, 39.8, 47.5, 55.1, 62.8, 70.4, 78.1, 85.7, 99.9)


class LinearModel:
    """Strains ``a(x, load) * 30 / E_c + b(x, load) * log10_K_r`` [µε], batched over `...`.

    Records every parameter vector it receives in ``calls``. ``nan_above`` makes it return NaN
    for ``E_c`` above that value (a failed run).
    """

    names = ("E_c", "log10_K_r")

    def __init__(
        self, x: np.ndarray, loads: tuple[float, ...] = PAPER_LOADS, nan_above: float = np.inf
    ):
        self.x = torch.as_tensor(x, dtype=torch.float64)
        self.loads = torch.as_tensor(loads, dtype=torch.float64)
        self.a = 40.0 * torch.sin(self.x[None] / 3.0 + self.loads[:, None])
        self.b = torch.cos(self.x[None] / 5.0 - self.loads[:, None])
        self.nan_above = nan_above
        self.calls: list[list[float]] = []

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        self.calls += theta_p.detach().reshape(-1, 2).tolist()
        e_c, k_r = theta_p[..., 0, None, None], theta_p[..., 1, None, None]
        out = self.a * (30.0 / e_c) + self.b * k_r
        return torch.where(e_c > self.nan_above, torch.nan, out)

    @staticmethod
    def default_priors() -> dict:
        """The paper's priors: the model stands in for bridge 705 (``Problem(priors=None)``)."""
        return paper_priors()


def c1_positions() -> np.ndarray:
    """The 351 fibre positions 35.0, 35.1, ..., 70.0 m."""
    return np.round(35.0 + 0.1 * np.arange(351), 10)


def synthetic(
    model: LinearModel, loads: tuple[float, ...], x: np.ndarray, seed: int = 0
) -> Measurements:
    """Measurements of ``model`` at E_c = 33, log10_K_r = 11.5 plus N(0, 0.5²) noise."""
    rng = np.random.default_rng(seed)
    full = model(torch.tensor([33.0, 11.5])).numpy()
    li = [int(np.argmin(np.abs(model.loads.numpy() - v))) for v in loads]
    xi = [int(np.argmin(np.abs(model.x.numpy() - v))) for v in x]
    model.calls.clear()
    y = full[np.ix_(li, xi)] + rng.normal(0.0, 0.5, (len(loads), len(x)))
    return Measurements(x, y, loads, sigma_e=0.1)
