"""Write ``campaign.csv``: a synthetic measurement campaign of the two-span beam, known truth.

    python examples/two_span_beam/make_campaign.py      # from the repository root

The strains are the model's at the true parameters, plus a Matérn 3/2 discrepancy (a smooth
error the model does not have: sigma_a, length below) and white measurement noise (sigma_e),
each load case drawn independently, seed fixed. The truth is stored in the file's metadata
(``truth_<name>``), so the corner plot of a run marks it.
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
from beam import TwoSpanBeam  # noqa: E402

#: the true parameters: physical (E [GPa], log10 k_A, log10 k_C [N·m/rad]) and statistical
TRUTH = {"E": 32.0, "log10_k_A": 8.2, "log10_k_C": 7.5, "sigma_a": 1.0, "length": 1.0}
SIGMA_E = 0.5  # measurement noise [µε]
SEED = 7


def campaign(seed: int = SEED) -> torchshm.Measurements:
    """Every load case of the model at 0.1 m pitch, with discrepancy and noise."""
    model = TwoSpanBeam()
    theta = torch.tensor([TRUTH[n] for n in model.names], dtype=torch.float64)
    eta = model(theta).numpy()  # L x n
    x = model.x.numpy()
    cov = get_kernel("matern32")(x, sigma_a=TRUTH["sigma_a"], length=TRUTH["length"]).numpy()
    factor = np.linalg.cholesky(cov + 1e-9 * np.eye(len(x)))
    rng = np.random.default_rng(seed)
    delta = rng.standard_normal(eta.shape) @ factor.T
    noise = SIGMA_E * rng.standard_normal(eta.shape)
    attrs = {"structure": "two-span continuous beam (torchshm example)", "seed": seed,
             **{f"truth_{k}": v for k, v in TRUTH.items()}}
    return torchshm.Measurements(x, eta + delta + noise, model.loads.numpy(), sigma_e=SIGMA_E, attrs=attrs)


if __name__ == "__main__":
    path = campaign().save(HERE / "campaign.csv")
    print(f"wrote {path}")
