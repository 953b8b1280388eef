"""A cheap analytic forward model for the checks of a fit: a simply supported beam's strains.

``Bending``: the bottom-fibre strain [µε] of a 10 m simply supported beam under a unit point
load at each load position, ``eta = 400 M(x; load) / E`` (so ``E = 32`` gives up to ~30 µε);
one physical parameter ``E`` [GPa]. :func:`bending_problem` makes data with a chosen
multiplicative error and noise and identifies ``E``, ``sigma_a`` and ``length``.
"""

from __future__ import annotations

import numpy as np
import torch

import torchshm


class Bending:
    """``model(theta_p `... x 1`) -> `... x 2 x 39``` strains [µε] at 0.25 m pitch."""

    names = ["E"]
    identity = "bending-test-model-v1"

    def __init__(self) -> None:
        self.x = torch.round(torch.arange(0.25, 10.0, 0.25, dtype=torch.float64) * 1e6) / 1e6
        self.loads = torch.tensor([3.0, 6.0], dtype=torch.float64)
        s, a = self.x[None, :], self.loads[:, None]
        self.shape = torch.where(s <= a, s * (10 - a) / 10, a * (10 - s) / 10)

    def __call__(self, theta_p: object) -> torch.Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        return 400.0 * self.shape / theta[..., :1, None]


def bending_problem(sigma_m_data: float, sigma_m: float = 0.05, sigma_e: float = 0.05,
                    seed: int = 0) -> torchshm.Problem:
    """Data ``eta(E=32) (1 + sigma_m_data z1) + sigma_e z2`` identified with ``sigma_m``."""
    model = Bending()
    rng = np.random.default_rng(seed)
    eta = model(torch.tensor([32.0])).numpy()
    y = eta * (1 + sigma_m_data * rng.standard_normal(eta.shape)) + sigma_e * rng.standard_normal(eta.shape)
    meas = torchshm.Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=sigma_e)
    priors = {"E": torchshm.Uniform(10.0, 60.0),
              "sigma_a": torchshm.Gamma(2.0, 2.0, bounds=(0.0, 5.0)),
              "length": torchshm.Gamma(3.0, 1.0, bounds=(0.0, 10.0))}
    return torchshm.Problem(model, meas, priors=priors, sigma_m=sigma_m)
