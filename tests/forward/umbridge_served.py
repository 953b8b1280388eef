"""A UM-Bridge server for the tests: ``python umbridge_served.py PORT`` serves on 127.0.0.1

* ``"linear"``: a model written against umbridge alone (not torchshm), strains
  ``theta_0 * sin(pi x / 3) + theta_1 * x / 3`` for each load case, scaled by ``1 + load / 10``,
  returned as `L` output vectors of `n` values, after ``config["sleep"]`` seconds (default 0);
* ``"served"``: the same strains from a torchshm-style forward model, through
  :class:`torchshm.forward.umbridge_server.ServedModel` (one output vector of `L n` values).
"""

from __future__ import annotations

import sys
import time

import numpy as np
import torch
import umbridge

X = np.linspace(0.0, 3.0, 31)
LOADS = np.array([10.0, 20.0])
BASIS = np.stack([np.sin(np.pi * X / 3.0), X / 3.0])  # P x n


def strains(theta: np.ndarray) -> np.ndarray:
    """`L x n` strains [µε] for θ `P`."""
    return (1.0 + LOADS[:, None] / 10.0) * (np.asarray(theta) @ BASIS)[None, :]


class Linear(umbridge.Model):
    def __init__(self) -> None:
        super().__init__("linear")

    def get_input_sizes(self, config=None):
        return [2]

    def get_output_sizes(self, config=None):
        return [len(X)] * len(LOADS)

    def __call__(self, parameters, config=None):
        time.sleep(float((config or {}).get("sleep", 0.0)))
        return strains(np.array(parameters[0])).tolist()

    def supports_evaluate(self):
        return True


class TorchLinear:
    """The same strains as a torchshm forward model."""

    names = ("a", "b")
    x = torch.as_tensor(X)
    loads = torch.as_tensor(LOADS)

    def __call__(self, theta_p):
        return torch.as_tensor(strains(np.asarray(theta_p)))


if __name__ == "__main__":
    from torchshm.forward.umbridge_server import ServedModel, serve_models

    serve_models([Linear(), ServedModel(TorchLinear(), "served")], port=int(sys.argv[1]))
