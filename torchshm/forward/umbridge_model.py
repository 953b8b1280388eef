"""A forward model served over UM-Bridge: a model in a container, on another machine, in any language.

`UM-Bridge <https://um-bridge-benchmarks.readthedocs.io>`_ serves a model over HTTP: it takes
a list of input vectors and returns a list of output vectors. :class:`UMBridgeModel` calls such
a server once per θp and reads its outputs as strains [µε] `L x n`: either one output vector of
`L n` values (load case after load case) or `L` vectors of `n` values. The θp is sent as one
input vector of `P` values, or as `P` vectors of one value when the server declares so.
Evaluations use the protocol's ``Evaluate`` request with a timeout (``umbridge.HTTPModel`` has
none); the server's sizes are checked when the model is made, before any run.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor


class UMBridgeError(RuntimeError):
    """A UM-Bridge evaluation failed: no answer in time, or the server reported an error."""


class UMBridgeModel:
    """A forward model whose runs are evaluations of a UM-Bridge model.

    Args:
        url: the server, e.g. ``"http://localhost:4242"``.
        name: the model's name on the server.
        x: sensor positions `n` [m] (or `n x d` coordinates) of the server's outputs.
        loads: load cases `L` of the server's outputs.
        names: parameter names; None: ``theta_0, theta_1, ...`` (their number from the server).
        config: the UM-Bridge ``config`` sent with every request (e.g. mesh level).
        timeout: seconds to wait for one evaluation; None: for ever.
        identity: key in an evaluation store; None: a hash of the name, config, sizes, x and
            loads (not the URL: the same model served elsewhere is the same model). Give a
            versioned one (``"my-bridge-v3"``) and change it when the served model changes.

    Raises:
        ValueError: when the server cannot be reached, does not serve ``name``, cannot
            evaluate, or its input or output sizes do not fit ``names``, ``x`` and ``loads``.
    """

    def __init__(self, url: str, name: str, x: object, loads: object, *,
                 names: Sequence[str] | None = None, config: Mapping[str, Any] | None = None,
                 timeout: float | None = 600.0, identity: str | None = None) -> None:
        self.url, self.name = str(url).rstrip("/"), str(name)
        self.x, self.loads = as_tensor(x).detach().clone(), as_tensor(loads).detach().clone()
        self.config = dict(config or {})
        self.timeout = timeout
        self.input_sizes, self.output_sizes = self._sizes()
        n_params = self.input_sizes[0] if len(self.input_sizes) == 1 else len(self.input_sizes)
        if len(self.input_sizes) > 1 and set(self.input_sizes) != {1}:
            raise ValueError(f"UM-Bridge model {name!r} takes inputs of sizes {self.input_sizes}; "
                             "expected one vector of P values or P single values")
        self.names = [f"theta_{i}" for i in range(n_params)] if names is None else [str(n) for n in names]
        if len(self.names) != n_params:
            raise ValueError(f"UM-Bridge model {name!r} takes {n_params} parameters, got names {self.names}")
        L, n = len(self.loads), len(self.x)
        if self.output_sizes not in ([L * n], [n] * L):
            raise ValueError(
                f"UM-Bridge model {name!r} returns outputs of sizes {self.output_sizes}; expected "
                f"[{L * n}] (L x n = {L} x {n}, load case after load case) or {L} outputs of {n}"
            )
        self.identity = identity if identity is not None else self._default_identity()

    def _sizes(self) -> tuple[list[int], list[int]]:
        import requests
        import umbridge

        try:
            client = umbridge.HTTPModel(self.url, self.name)
            if not client.supports_evaluate():
                raise ValueError(f"UM-Bridge model {self.name!r} at {self.url} does not support Evaluate")
            return list(client.get_input_sizes(self.config)), list(client.get_output_sizes(self.config))
        except requests.RequestException as exc:
            raise ValueError(f"cannot reach the UM-Bridge server {self.url}: {type(exc).__name__}") from None
        except ValueError:
            raise
        except Exception as exc:  # umbridge raises plain Exception for an unknown model
            raise ValueError(f"UM-Bridge server {self.url}: {str(exc).splitlines()[0]}") from None

    def __repr__(self) -> str:
        return f"UMBridgeModel({self.url!r}, {self.name!r}, n={len(self.x)}, L={len(self.loads)})"

    def __call__(self, theta_p: object) -> Tensor:
        """Strains [µε] `... x L x n` for parameters `... x P`, one evaluation per row."""
        theta = as_tensor(theta_p).detach()
        rows = theta.reshape(-1, theta.shape[-1]).cpu().numpy()
        out = np.stack([self.run(row) for row in rows]) if len(rows) else np.empty((0, len(self.loads), len(self.x)))
        return torch.from_numpy(out).reshape(*theta.shape[:-1], len(self.loads), len(self.x))

    def run(self, theta: np.ndarray) -> np.ndarray:
        """One evaluation for parameters `P`; strains [µε] `L x n`.

        Raises:
            UMBridgeError: no answer within ``timeout``, a connection error, or an error
                reported by the server.
        """
        import requests

        values = [float(v) for v in np.asarray(theta, dtype=np.float64).reshape(-1)]
        inputs = [values] if len(self.input_sizes) == 1 else [[v] for v in values]
        request = {"name": self.name, "input": inputs, "config": self.config}
        try:
            response = requests.post(f"{self.url}/Evaluate", json=request, timeout=self.timeout)
            answer = response.json()
        except requests.Timeout:
            raise UMBridgeError(f"{self.url} gave no answer within {self.timeout:g} s") from None
        except (requests.RequestException, ValueError) as exc:
            raise UMBridgeError(f"{self.url}: {type(exc).__name__}: {exc}") from None
        if "error" in answer:
            error = answer["error"]
            raise UMBridgeError(f"{self.url} model {self.name!r}: {error.get('type')}: {error.get('message')}")
        return np.asarray(answer["output"], dtype=np.float64).reshape(len(self.loads), len(self.x))

    def _default_identity(self) -> str:
        spec = json.dumps({"name": self.name, "config": self.config, "in": self.input_sizes,
                           "out": self.output_sizes}, sort_keys=True)
        digest = hashlib.sha256(spec.encode())
        digest.update(self.x.numpy().tobytes())
        digest.update(self.loads.numpy().tobytes())
        return f"UMBridgeModel-{self.name}-{digest.hexdigest()[:16]}"


__all__ = ["UMBridgeError", "UMBridgeModel"]
