"""Write ``campaign.csv`` and ``truth.json``: a measurement campaign made by CalculiX itself.

    python examples/calculix_slab/make_campaign.py      # from the repository root (needs ccx)

The strains are CalculiX's at the true parameters ``TRUTH`` (one ``ccx`` run), with the three
errors of the paper's Eq. (21), drawn once with a fixed seed for every load case:

* a point-wise model error of ``SIGMA_M`` = 2 % of each strain (``likelihood.sigma_m``),
* a smooth discrepancy the model does not have: a Matérn 3/2 Gaussian process of the position
  along the fibre (``sigma_a`` 4 µε, ``length`` 1.5 m),
* white measurement noise ``SIGMA_E`` = 2 µε (a distributed fibre-optic sensor's repeatability,
  stored in the file as ``sigma_e``).

The truth also goes into the file's metadata (``truth_<name>``), so the corner plot marks it.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import torchshm  # noqa: E402
from torchshm.kernels import get_kernel  # noqa: E402
from slab import calculix_slab  # noqa: E402

TRUTH = {"E": 34.0, "log10_k_B": 6.3, "sigma_a": 4.0, "length": 1.5}
SIGMA_M = 0.02  # point-wise model error, relative
SIGMA_E = 2.0  # measurement noise [µε]
SEED = 20


def campaign(seed: int = SEED) -> torchshm.Measurements:
    """All four load cases at the 201 fibre points, CalculiX's strains plus the errors above."""
    with tempfile.TemporaryDirectory() as runs:
        model = calculix_slab(workdir=runs, keep="none")
        theta = torch.tensor([TRUTH[n] for n in model.names], dtype=torch.float64)
        eta = model(theta).numpy()  # L x n [µε]
    x = model.x.numpy()
    cov = get_kernel("matern32")(x, sigma_a=TRUTH["sigma_a"], length=TRUTH["length"]).numpy()
    factor = np.linalg.cholesky(cov + 1e-9 * np.eye(len(x)))
    rng = np.random.default_rng(seed)
    model_error = SIGMA_M * np.abs(eta) * rng.standard_normal(eta.shape)
    delta = rng.standard_normal(eta.shape) @ factor.T
    noise = SIGMA_E * rng.standard_normal(eta.shape)
    attrs = {"structure": "two-span slab strip, CalculiX (torchshm example)", "seed": seed,
             "sigma_m": SIGMA_M, **{f"truth_{k}": v for k, v in TRUTH.items()}}
    return torchshm.Measurements(x, eta + model_error + delta + noise, model.loads.numpy(),
                                 sigma_e=SIGMA_E, attrs=attrs)


if __name__ == "__main__":
    path = campaign().save(HERE / "campaign.csv")
    truth = {**TRUTH, "sigma_m": SIGMA_M, "sigma_e": SIGMA_E, "seed": SEED}
    (HERE / "truth.json").write_text(json.dumps(truth, indent=1) + "\n")
    print(f"wrote {path} and {HERE / 'truth.json'}")
