"""A forward model for the Dask tests (importable by Dask's worker processes)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import torch
from torch import Tensor


class Counted:
    """``strain[l, i] = (a x_i + b) load_l``; each run appends ``<a> <pid>`` to ``counter``.

    A run with ``a >= slow`` first writes its pid to ``<counter>.slow-<a>``, then sleeps
    ``delay`` seconds (a stand-in for a long FE run).
    """

    identity = "dask-counted-v1"
    names = ("a", "b")

    def __init__(self, counter: str, slow: float = float("inf"), delay: float = 0.0) -> None:
        self.x = torch.linspace(0.0, 1.0, 6, dtype=torch.float64)
        self.loads = torch.tensor([1.0, 2.0], dtype=torch.float64)
        self.counter, self.slow, self.delay = counter, slow, delay

    def __call__(self, theta_p: Tensor) -> Tensor:
        t = torch.as_tensor(theta_p, dtype=torch.float64)
        for row in t.reshape(-1, 2):
            with open(self.counter, "a") as handle:
                handle.write(f"{float(row[0])!r} {os.getpid()} {os.environ.get('OMP_NUM_THREADS')}\n")
            if float(row[0]) >= self.slow:
                Path(f"{self.counter}.slow-{float(row[0])!r}").write_text(str(os.getpid()))
                time.sleep(self.delay)
        return (t[..., 0, None, None] * self.x + t[..., 1, None, None]) * self.loads[:, None]


def calls(counter: str | Path) -> list[tuple[float, int, str]]:
    """``(a, pid, OMP_NUM_THREADS)`` of every run, in order."""
    rows = [line.split() for line in Path(counter).read_text().splitlines()]
    return [(float(a), int(pid), omp) for a, pid, omp in rows]
