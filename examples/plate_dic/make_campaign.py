"""Write ``campaign.csv``: a synthetic image-correlation campaign of the plate, known truth.

    python examples/plate_dic/make_campaign.py      # from the repository root

The strains ``eps_xx`` are the model's at the true parameters, drawn from the likelihood's own
generative model (Eq. 21): a multiplicative model error ``sigma_m``, a Matérn 3/2 discrepancy of
the Euclidean distance between the points (``sigma_a``, ``length`` below: a smooth field the
model does not have) and white measurement noise ``sigma_e``, each load case drawn
independently, seed fixed. The truth is stored in the file's metadata (``truth_<name>``), so the
corner plot of a run marks it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import torchshm  # noqa: E402
from torchshm.kernels import get_kernel  # noqa: E402
from plate import PlateDIC  # noqa: E402

#: the true parameters: physical (E [GPa], log10 k [N·m/rad/m]) and statistical (µε, m)
TRUTH = {"E": 32.0, "log10_k": 6.5, "sigma_a": 4.0, "length": 0.3}
SIGMA_E = 3.0  # measurement noise [µε]
SIGMA_M = 0.02  # multiplicative model error (identify with likelihood.sigma_m=0.02)
SEED = 11


def campaign(seed: int = SEED) -> torchshm.Measurements:
    """Every load case of the model on its 192-point grid, with model error, discrepancy and noise."""
    model = PlateDIC()
    theta = torch.tensor([TRUTH[n] for n in model.names], dtype=torch.float64)
    eta = model(theta).numpy()  # L x n
    xy = model.x.numpy()  # n x 2
    cov = get_kernel("matern32")(xy, sigma_a=TRUTH["sigma_a"], length=TRUTH["length"]).numpy()
    factor = np.linalg.cholesky(cov + 1e-9 * np.eye(len(xy)))
    rng = np.random.default_rng(seed)
    error = SIGMA_M * eta * rng.standard_normal(eta.shape)
    delta = rng.standard_normal(eta.shape) @ factor.T
    noise = SIGMA_E * rng.standard_normal(eta.shape)
    attrs = {"structure": "slab under a patch load, image correlation (torchshm example)", "seed": seed,
             "sigma_m": SIGMA_M, **{f"truth_{k}": v for k, v in TRUTH.items()}}
    return torchshm.Measurements(xy, eta + error + delta + noise, model.loads.numpy(), sigma_e=SIGMA_E, attrs=attrs)


if __name__ == "__main__":
    path = campaign().save(HERE / "campaign.csv")
    print(f"wrote {path}")
