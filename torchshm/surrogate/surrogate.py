"""The fitted surrogate: a forward model that predicts a GP's posterior mean, and its file format.

A :class:`Surrogate` is itself a forward model (``x``, ``loads``, ``sur(theta_p)``) and can
replace the model it was trained on anywhere in torchshm. Its file holds only tensors and plain
Python values (``torch.load(..., weights_only=True)`` reads it): the training design and
outputs, the transform and the GP's state dict; loading never needs the original model.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor
from torchshm.surrogate.gp import SharedKernelGP
from torchshm.surrogate.transforms import ResponseTransform

#: format tag written into every surrogate file
FILE_FORMAT = "torchshm-surrogate/1"


class Surrogate:
    """GP surrogate of a forward model, usable as a forward model.

    Attributes:
        x: `n` sensor positions [m], copied from the model.
        loads: `L` load cases (front-axle positions [m]), copied from the model.
        names: names of the `P` physical parameters, in θp order.
        model_identity: identity of the model it was trained on.
        identity: identity of this surrogate (a hash of its training data and
            hyperparameters), distinct from ``model_identity`` so that an evaluation store
            never mixes surrogate and model outputs.
        theta_p: `N x P` design the GP was trained on (successful runs only).
        outputs: `N x L x n` model strains [µε] at the design.
        metadata: plain values describing the fit (marginal likelihood, settings, versions).
        surrogate_transform: the transform keywords it was fitted with (those of the model
            it replaces), so that a surrogate of a surrogate, or an emulator of its outputs,
            uses the same structure.
    """

    def __init__(self, gp: SharedKernelGP, transform: ResponseTransform, x: Tensor,
                 loads: Tensor, names: tuple[str, ...], model_identity: str, theta_p: Tensor,
                 outputs: Tensor, metadata: dict[str, Any] | None = None) -> None:
        self.gp, self.transform = gp, transform
        self.x, self.loads = as_tensor(x).detach(), as_tensor(loads).detach()
        self.names, self.model_identity = tuple(names), str(model_identity)
        self.theta_p, self.outputs = theta_p, outputs
        self.metadata = dict(metadata or {})
        self._scaled_weights = gp.weights * transform.scale
        self.identity = f"surrogate-{self._digest()}"

    @property
    def surrogate_transform(self) -> dict[str, Any]:
        """Keywords of :meth:`ResponseTransform.fit` this surrogate was fitted with."""
        return self.transform.options()

    def __repr__(self) -> str:
        return (f"Surrogate(of={self.model_identity!r}, N={self.theta_p.shape[0]}, "
                f"L={self.loads.numel()}, n={self.x.shape[0]}, kernel={self.gp.kernel!r})")

    def __call__(self, theta_p: Tensor | np.ndarray) -> Tensor:
        """Posterior mean strains [µε] `... x L x n` at physical parameters `... x P`."""
        return self.predict(theta_p, variance=False)[0]

    def variance(self, theta_p: Tensor | np.ndarray) -> Tensor:
        """Predictive variance [µε²] `... x L x n` of the latent (noise-free) response."""
        return self.predict(theta_p, variance=True)[1]

    def predict(self, theta_p: Tensor | np.ndarray, variance: bool = True,
                chunk: int = 4096) -> tuple[Tensor, Tensor | None]:
        """Posterior mean [µε] and, when asked, variance [µε²], both `... x L x n`.

        Differentiable with respect to ``theta_p``. Batches are evaluated ``chunk`` points
        at a time to bound memory.
        """
        theta = as_tensor(theta_p)
        if theta.shape[-1] != len(self.names):
            raise ValueError(f"theta_p must end in {len(self.names)} parameters "
                             f"{self.names}, got shape {tuple(theta.shape)}")
        batch, flat = theta.shape[:-1], theta.reshape(-1, theta.shape[-1])
        means, variances = [], []
        for part in flat.split(chunk) if flat.shape[0] else [flat]:
            mean, var = self._predict_flat(part, variance)
            means.append(mean)
            if var is not None:
                variances.append(var)
        shape = (*batch, self.loads.numel(), self.x.shape[0])
        mean = torch.cat(means).reshape(shape)
        return mean, (torch.cat(variances).reshape(shape) if variance else None)

    def _predict_flat(self, theta: Tensor, variance: bool) -> tuple[Tensor, Tensor | None]:
        """Mean [µε] and variance [µε²], `T x m`, for `T x P` parameters.

        Equals ``transform.strains(theta, gp.predict(...))`` with the output scale folded
        into the GP weights, so that a large batch makes one `T x m` pass, not three.
        """
        inputs, factor = self.transform.inputs(theta), self.transform.factor(theta)
        cross = self.gp.cross_covariance(inputs)
        mean = torch.addmm(self.transform.offset, cross, self._scaled_weights)
        mean = mean * factor if torch.is_grad_enabled() else mean.mul_(factor)
        if not variance:
            return mean, None
        latent = self.gp.latent_variance(inputs, cross) * factor.square()
        return mean, latent * self.transform.scale.square()

    def save(self, path: str | Path) -> None:
        """Write the surrogate to ``path`` (``torch.save`` of tensors and plain values, with a
        SHA-256 checksum of the content; written to a temporary file and renamed, so an
        interrupted save never leaves a damaged file in place of a good one).

        Raises:
            OSError: if the file cannot be written (one line naming it).
        """
        path = Path(path)
        state = self.state()
        state["checksum"] = state_checksum(state)
        temporary = path.with_name(path.name + ".tmp")
        try:
            torch.save(state, temporary)
            os.replace(temporary, path)
        except (OSError, RuntimeError) as exc:  # torch reports a failed write as RuntimeError
            if temporary.is_file():
                temporary.unlink()
            raise OSError(f"cannot write surrogate file {path}: {_first_line(exc)}") from None

    def state(self) -> dict[str, Any]:
        """Everything needed to rebuild the surrogate, ``weights_only``-loadable."""
        return {
            "format": FILE_FORMAT, "x": self.x, "loads": self.loads, "names": list(self.names),
            "model_identity": self.model_identity, "theta_p": self.theta_p,
            "outputs": self.outputs, "kernel": self.gp.kernel, "min_noise": self.gp.min_noise,
            "transform": self.transform.state(), "gp": dict(self.gp.state_dict()),
            "metadata": self.metadata,
        }

    def _digest(self) -> str:
        digest = hashlib.sha256(self.model_identity.encode())
        for tensor in (self.theta_p, self.outputs, *self.gp.state_dict().values()):
            digest.update(tensor.detach().cpu().numpy().tobytes())
        digest.update(repr((self.gp.kernel, self.transform.log_inputs, self.transform.modulus,
                            self.transform.relative_to_modulus)).encode())
        return digest.hexdigest()[:16]


def build_gp(transform: ResponseTransform, theta_p: Tensor, outputs: Tensor, kernel: str,
             min_noise: float) -> SharedKernelGP:
    """The (unfitted) GP on a transformed design; ``outputs`` is `N x L x n` [µε]."""
    flat = outputs.reshape(outputs.shape[0], -1)
    targets = transform.targets(theta_p, flat).mT.contiguous()
    return SharedKernelGP(transform.inputs(theta_p), targets, kernel=kernel, min_noise=min_noise)


def load_surrogate(path: str | Path) -> Surrogate:
    """Read a surrogate written by :meth:`Surrogate.save`; the model is not needed.

    Raises:
        ValueError: if the file is not a torchshm surrogate, is truncated or damaged (its
            checksum, when it has one, does not match), or holds Python objects (never
            unpickled). One line naming the file.
    """
    try:
        state = torch.load(Path(path), map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise
    except pickle.UnpicklingError as exc:
        if "Unsupported global" in str(exc):
            raise ValueError(f"{path} is not a torchshm surrogate file: it holds Python "
                             f"objects, which are not loaded (unpickling can run code)") from None
        raise ValueError(f"{path} is not a readable torchshm surrogate file (truncated, "
                         f"damaged or not a PyTorch file)") from None
    except Exception as exc:  # truncated or damaged zip archive, or not one at all
        raise ValueError(f"{path} is not a readable torchshm surrogate file (truncated or "
                         f"damaged?): {_first_line(exc)}") from None
    if not isinstance(state, dict) or state.get("format") != FILE_FORMAT:
        raise ValueError(f"{path} is not a torchshm surrogate file ({FILE_FORMAT})")
    if "checksum" in state and state.pop("checksum") != state_checksum(state):
        raise ValueError(f"{path} is damaged: its content does not match its checksum")
    transform = ResponseTransform.from_state(state["transform"])
    gp = build_gp(transform, state["theta_p"], state["outputs"], state["kernel"],
                  state["min_noise"])
    gp.load_state_dict(state["gp"])
    gp.freeze()
    return Surrogate(gp, transform, state["x"], state["loads"], tuple(state["names"]),
                     state["model_identity"], state["theta_p"], state["outputs"],
                     state["metadata"])


def state_checksum(state: dict[str, Any]) -> str:
    """SHA-256 over a surrogate state's keys, tensors (bytes) and plain values (repr)."""
    digest = hashlib.sha256()

    def add(value: Any) -> None:
        if isinstance(value, Tensor):
            digest.update(repr((str(value.dtype), tuple(value.shape))).encode())
            digest.update(value.detach().cpu().contiguous().numpy().tobytes())
        elif isinstance(value, dict):
            for key in sorted(value, key=str):
                if key != "checksum":
                    digest.update(repr(key).encode())
                    add(value[key])
        elif isinstance(value, (list, tuple)):
            digest.update(b"[")
            for item in value:
                add(item)
            digest.update(b"]")
        else:
            digest.update(repr(value).encode())

    add(state)
    return digest.hexdigest()


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[0] if lines else type(exc).__name__
