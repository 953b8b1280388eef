"""A small stand-in forward model with the structure of the bridge 705 frame model."""

from __future__ import annotations

import torch
from torch import Tensor


class StandInFrame:
    """Strains ``ε = g(x, load, κ) / E`` with a sigmoid in log10 κ, κ = K / E.

    Mimics a linear elastic frame with rotational springs: θp = (E [GPa], log10 K),
    outputs `... x L x n` [µε]; ``calls`` counts evaluated parameter vectors.
    """

    names = ("E_c", "log10_K_r")
    surrogate_transform = {"log_inputs": (0,), "modulus": 0, "relative_to_modulus": (1,)}
    identity = "stand-in-frame/1"

    def __init__(self, n: int = 25, loads: tuple[float, ...] = (10.0, 20.0, 30.0)) -> None:
        self.x = torch.linspace(0.0, 35.0, n, dtype=torch.float64)
        self.loads = torch.tensor(loads, dtype=torch.float64)
        self.calls = 0

    def __call__(self, theta_p: Tensor) -> Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        self.calls += theta[..., 0].numel()
        e_c, log_k = theta[..., 0, None, None], theta[..., 1, None, None]
        fixity = torch.sigmoid((log_k - torch.log10(e_c) - 8.0) / 0.6)
        x, load = self.x, self.loads[:, None]
        sagging = 400.0 * torch.exp(-(((x - load) / 6.0) ** 2))
        hogging = -150.0 * torch.exp(-(((x - 17.5) / 3.0) ** 2)) * (1.0 + 0.01 * load)
        return (sagging + fixity * (hogging - 0.3 * sagging)) / e_c
