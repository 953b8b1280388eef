"""Serving a torchshm forward model (a fitted :class:`~torchshm.surrogate.Surrogate`, say) over UM-Bridge.

Other UQ tools (UM-Bridge clients in Python, C++, Julia, R, MATLAB) can then evaluate it:
input one vector of `P` physical parameters, output one vector of `L n` strains [µε], load
case after load case (the layout :class:`~torchshm.forward.UMBridgeModel` reads back)::

    python -m torchshm.forward.umbridge_server runs/surrogate.pt --port 4242

``umbridge.serve_models`` listens on every interface; :func:`serve_models` here binds the
address you give (default ``127.0.0.1``: this machine only).
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Sequence
from typing import Any
from unittest import mock

import numpy as np
import torch
import umbridge

from torchshm.forward.protocol import output_shape


class ServedModel(umbridge.Model):
    """A torchshm forward model as a UM-Bridge model.

    Args:
        model: a forward model (``model(theta_p) -> L x n``, ``x``, ``loads``).
        name: its name on the server.
        n_params: number of physical parameters `P`; default ``len(model.names)``.
    """

    def __init__(self, model: Any, name: str = "forward", n_params: int | None = None) -> None:
        super().__init__(name)
        self.model = model
        names = getattr(model, "names", None)
        if n_params is None and names is None:
            raise ValueError("n_params is needed for a model without names")
        self.n_params = int(n_params if n_params is not None else len(names))
        self.shape = output_shape(model)

    def get_input_sizes(self, config: dict[str, Any] | None = None) -> list[int]:
        return [self.n_params]

    def get_output_sizes(self, config: dict[str, Any] | None = None) -> list[int]:
        return [self.shape[0] * self.shape[1]]

    def __call__(self, parameters: list[list[float]], config: dict[str, Any] | None = None) -> list[list[float]]:
        with torch.no_grad():
            out = self.model(torch.as_tensor(parameters[0], dtype=torch.float64))
        return [np.asarray(out, dtype=np.float64).reshape(-1).tolist()]

    def supports_evaluate(self) -> bool:
        return True


def serve_models(models: Sequence[umbridge.Model], port: int = 4242, host: str = "127.0.0.1") -> None:
    """Serve UM-Bridge models on ``host:port`` until the process is stopped (blocks)."""
    from aiohttp import web

    bound = functools.partial(web.run_app, host=host, print=None)
    with mock.patch.object(umbridge.um.web, "run_app", bound):
        umbridge.serve_models(list(models), port=port)


def main(argv: Sequence[str] | None = None) -> None:
    """``python -m torchshm.forward.umbridge_server SURROGATE.pt [--port] [--host] [--name]``."""
    from torchshm.surrogate import load_surrogate

    parser = argparse.ArgumentParser(description="Serve a fitted torchshm surrogate over UM-Bridge.")
    parser.add_argument("surrogate", help="a file written by Surrogate.save")
    parser.add_argument("--port", type=int, default=4242)
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: every interface)")
    parser.add_argument("--name", default="forward", help="the model's name on the server")
    parser.add_argument("--n-params", type=int, default=None, help="P, when the surrogate has no names")
    args = parser.parse_args(argv)
    surrogate = load_surrogate(args.surrogate)
    serve_models([ServedModel(surrogate, args.name, args.n_params)], args.port, args.host)


if __name__ == "__main__":
    main()


__all__ = ["ServedModel", "serve_models"]
