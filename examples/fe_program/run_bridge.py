#!/usr/bin/env python
"""A stand-in for a user's finite element program, following the file contract of
docs/external_models.md: run in its work folder, it reads ``params.json`` (θp = ``E_c`` [GPa],
``log10_K_r``; the load cases and sensor positions [m] to report) and writes the strains [µε]
``L x n`` to ``strains.npz``. The strains are those of ``torchshm.bridge705()`` (the bridge's
torch finite element model) at the asked load cases, linear between its sensors; a real program
(DIANA, Abaqus, OpenSees, ...) would be run here instead, e.g. by a shell script.
"""

from __future__ import annotations

import numpy as np
import torch

import torchshm
from torchshm.forward import read_params, write_strains
from torchshm.casestudy import Bridge705Config


def main() -> None:
    params = read_params()
    x, loads = np.asarray(params["x"], dtype=float), tuple(float(v) for v in params["loads"])
    model = torchshm.bridge705(Bridge705Config(loads=loads))
    with torch.no_grad():
        strain = model(torch.tensor(params["theta_p"], dtype=torch.float64)).numpy()  # L x n_model
    strain = np.stack([np.interp(x, model.x.numpy(), row) for row in strain])  # L x n
    write_strains("strains.npz", strain, x, np.asarray(loads))


if __name__ == "__main__":
    main()
