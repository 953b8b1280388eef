"""The one fit recipe of every GP field emulator in torchshm.

The FE-response surrogate (:func:`torchshm.fit_surrogate`), the adaptive method's field
emulator (``method="emulator"``) and the posterior predictive's emulator of stored runs all fit
the same model, a :class:`~torchshm.surrogate.gp.SharedKernelGP` over model runs, through
:func:`fit_field`:

1. **clean rows**: runs with a non-finite output or parameter (failed runs) are left out, and
   a repeated θp keeps its first run;
2. **transforms as objects**: a :class:`~torchshm.surrogate.ResponseTransform` maps θp to the
   unit box (log10 / modulus-relative columns when the model declares its structure) and the
   strains to standardised targets;
3. **output compression**: with more outputs `m` than runs `N`, the hyperparameters are fitted
   on `N` compressed targets with the same marginal likelihood (:func:`compressed_targets`), so
   an optimiser step costs O(N³) instead of O(N² m); the GP keeps every output to predict;
4. **warm start**: given the hyperparameters of an earlier fit (a design that has grown by a
   batch), one restart starts from them.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from linear_operator.utils.warnings import NumericalWarning
from torch import Tensor

from torchshm.surrogate.gp import SharedKernelGP
from torchshm.surrogate.transforms import PLAIN, ResponseTransform


@dataclass
class FieldFit:
    """A fitted field GP with its transform and the clean design it was trained on.

    Attributes:
        gp: the frozen GP (targets: every output).
        transform: θp and strain transform.
        theta_p: `N x P` clean design [model units].
        outputs: `N x L x n` its strains [µε].
        log_marginal_likelihood: the fit's mean log marginal likelihood per output and run.
    """

    gp: SharedKernelGP
    transform: ResponseTransform
    theta_p: Tensor
    outputs: Tensor
    log_marginal_likelihood: float


def clean_design(theta_p: object, outputs: object) -> tuple[Tensor, Tensor]:
    """Drop rows with non-finite values and repeated ``theta_p`` rows (first kept, to 12
    decimals).

    Args:
        theta_p: `M x P` physical parameters.
        outputs: `M x ...` model outputs [µε].

    Returns:
        ``(theta_p, outputs)`` restricted to the usable rows, float64 tensors.
    """
    theta = torch.as_tensor(np.asarray(theta_p), dtype=torch.float64)
    out = torch.as_tensor(np.asarray(outputs), dtype=torch.float64)
    if theta.shape[0] == 0:
        return theta, out
    keep = torch.isfinite(out.reshape(out.shape[0], -1)).all(-1) & torch.isfinite(theta).all(-1)
    theta, out = theta[keep], out[keep]
    _, first = np.unique(theta.numpy().round(12), axis=0, return_index=True)
    index = torch.as_tensor(np.sort(first), dtype=torch.long)
    return theta[index], out[index]


def fit_field(
    theta_p: object, outputs: object, *, transform: dict[str, Any] | ResponseTransform | None = None,
    kernel: str = "rbf", min_noise: float = 1e-10, lengthscales: tuple[float, ...] = (0.2, 0.5, 1.0),
    max_iter: int = 200, warm: dict[str, Tensor] | None = None, what: str = "emulator",
) -> FieldFit:
    """Fit a shared-kernel GP to model runs (module docstring: clean, transform, compress, fit).

    Args:
        theta_p: `M x P` physical parameters of the runs.
        outputs: `M x L x n` their strains [µε]; failed (non-finite) and repeated rows dropped.
        transform: keywords of :meth:`ResponseTransform.fit` (default :data:`PLAIN`), or a
            fitted transform to reuse as it is.
        kernel: "rbf" or "matern52" (ARD, with an output scale), or either with ``_additive``
            (plus one kernel per input: :data:`~torchshm.surrogate.gp.SURROGATE_KERNELS`).
        min_noise: lower bound of the GP noise variance (standardised units).
        lengthscales: initial lengthscales of the marginal-likelihood restarts.
        max_iter: L-BFGS iterations per restart.
        warm: hyperparameters of an earlier fit (``SharedKernelGP.hyperparameters()``): one
            more restart starts from them, first.
        what: the caller's name, for the error message.

    Raises:
        ValueError: with fewer than `P + 2` usable runs.
    """
    theta, out = clean_design(theta_p, outputs)
    n_params = int(np.shape(np.asarray(theta_p))[-1]) if np.ndim(np.asarray(theta_p)) == 2 else 0
    if theta.shape[0] < n_params + 2:
        raise ValueError(f"{what}: {theta.shape[0]} distinct successful runs; at least "
                         f"{n_params + 2} are needed to fit the GP")
    flat = out.reshape(theta.shape[0], -1)
    if isinstance(transform, ResponseTransform):
        scaling = transform
    else:
        options = dict(PLAIN if transform is None else transform)
        scaling = ResponseTransform.fit(theta, flat, standardize="output", **options)
    targets = scaling.targets(theta, flat).mT.contiguous()  # m x N
    inputs = scaling.inputs(theta)
    gp = SharedKernelGP(inputs, targets, kernel=kernel, min_noise=min_noise)
    fitted = gp
    if targets.shape[0] > targets.shape[1]:  # more outputs than runs: fit on N compressed ones
        fitted = SharedKernelGP(inputs, compressed_targets(targets), kernel, min_noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumericalWarning)  # jitter on near noise-free runs
        log_ml = fitted.fit(lengthscales=lengthscales, max_iter=max_iter, warm=warm)
        if fitted is not gp:
            gp.load_state_dict(fitted.state_dict())
            gp.freeze()
    return FieldFit(gp, scaling, theta, out, float(log_ml))


def compressed_targets(targets: Tensor) -> Tensor:
    """`N x N` targets ``Y'`` with ``Y'ᵀY' / N = YᵀY / m`` for `m x N` targets ``Y``: the same
    mean log marginal likelihood per output for every kernel and noise, which depends on the
    targets only through ``YᵀY``.

    ``Y' = sqrt(N / m) diag(sqrt(w)) Vᵀ`` from the eigendecomposition ``YᵀY = V diag(w) Vᵀ``.
    """
    m, N = targets.shape
    w, V = torch.linalg.eigh(targets.mT @ targets)
    return (V * (w.clamp_min(0.0) * (N / m)).sqrt()).mT.contiguous()
