"""Small forward models for the storage tests (importable by worker processes)."""

from __future__ import annotations

import os
import time

import numpy as np
import torch
from torch import Tensor


def grid(n_e: int = 5, n_k: int = 4) -> np.ndarray:
    """Grid of (E_c [GPa], log10_K_r) values `n_e * n_k x 2`, like the paper's design."""
    e_values, k_values = np.linspace(10.0, 100.0, n_e), np.linspace(0.0, 12.0, n_k)
    return np.array([[e, k] for e in e_values for k in k_values])


def strain_function(theta: Tensor, x: Tensor, loads: Tensor) -> Tensor:
    """Analytic strains [µε] `L x n` for θp `2`."""
    e_c, log_k = theta[0], theta[1]
    return 1e3 * loads[:, None] * torch.sin(x[None, :]) / e_c + log_k * x[None, :] ** 2


class GridModel:
    """Analytic forward model with a delay, a call log, and chosen failing θp.

    Args:
        delay: seconds each call sleeps (a stand-in for a slow FE run).
        counter: file to which each call appends ``start <θp>`` and ``end <θp>`` lines.
        fail: (E_c, log10_K_r) -> "raise" | "nan" | "inf" | "shape" | "exit".
    """

    identity = "grid-model-v1"

    def __init__(
        self, delay: float = 0.0, counter: str | None = None,
        fail: dict[tuple[float, float], str] | None = None,
    ) -> None:
        self.x = torch.linspace(0.0, 3.0, 7, dtype=torch.float64)
        self.loads = torch.tensor([10.0, 20.0, 30.0], dtype=torch.float64)
        self.delay, self.counter, self.fail = delay, counter, dict(fail or {})

    def _log(self, what: str, theta: Tensor) -> None:
        if self.counter is not None:
            with open(self.counter, "a") as handle:
                values = ",".join(f"{v:.12g}" for v in theta.tolist())
                handle.write(f"{what} {values} {os.getpid()}\n")

    def __call__(self, theta_p: Tensor) -> Tensor:
        theta = theta_p.reshape(-1)
        self._log("start", theta)
        time.sleep(self.delay)
        mode = self.fail.get((round(float(theta[0]), 9), round(float(theta[1]), 9)))
        out = strain_function(theta, self.x, self.loads)
        if mode == "raise":
            raise RuntimeError(f"solver diverged at E_c={float(theta[0]):g}")
        if mode == "nan":
            out[1, 2] = float("nan")
        if mode == "inf":
            out[0, 0] = float("inf")
        if mode == "shape":
            out = out[:, :-1]
        if mode == "exit":
            os._exit(3)
        self._log("end", theta)
        return out


def read_counter(path: str) -> list[tuple[str, str, int]]:
    """Lines of a counter file as (start|end, θp text, pid)."""
    if not os.path.exists(path):
        return []
    with open(path) as handle:
        return [(w, key, int(pid)) for w, key, pid in (line.split() for line in handle)]
