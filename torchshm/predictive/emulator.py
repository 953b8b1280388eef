"""Gaussian-process emulator of stored model outputs (paper, Sec. 2.4.1 and Sec. 4).

Inference already evaluated the forward model at a few hundred physical parameter vectors
`theta_p`, for *all* its load cases. The emulator is the library's FE-response surrogate
(:mod:`torchshm.surrogate`: zero-mean GPs of all outputs with one shared kernel, fitted by the
exact marginal likelihood) trained on those stored pairs, restricted to the prediction load
cases and positions. Nothing here calls a forward model: the emulator sees arrays only.

Input and output transforms (see :mod:`torchshm.surrogate.transforms`) are chosen by
:func:`transform_options`: the surrogate's own when the problem's model is a surrogate, the
model's ``surrogate_transform`` attribute when it declares one, plain scaling otherwise.

At dense sensing (thousands of positions, so ``m`` = load cases x positions outputs in the
tens of thousands) the hyperparameters are fitted on ``N`` compressed outputs: the mean log
marginal likelihood per output, ``-tr(C⁻¹ YᵀY) / (2m) - log|C| / 2 - N log(2 pi) / 2``,
depends on the `m x N` targets ``Y`` only through ``YᵀY`` (`N x N`), so any ``Y'`` with
``Y'ᵀY' / m' = YᵀY / m`` gives the same objective and optimum; each optimiser step then costs
O(N³) instead of O(N² m). The fitted GP keeps all `m` outputs for prediction.
"""

from __future__ import annotations

import warnings
from typing import Any, Sequence

import numpy as np
import torch
from linear_operator.utils.warnings import NumericalWarning
from torch import Tensor

from torchshm.forward.protocol import ForwardModel
from torchshm.surrogate import ResponseTransform, Surrogate
from torchshm.surrogate.gp import SharedKernelGP
from torchshm.surrogate.surrogate import build_gp
from torchshm.surrogate.transforms import PLAIN, transform_of


def transform_options(model: ForwardModel) -> dict[str, Any]:
    """Transform keywords suited to a forward model (see the module docstring)."""
    return transform_of(model)


def clean_design(theta_p: object, outputs: object) -> tuple[Tensor, Tensor]:
    """Drop rows with non-finite values and repeated `theta_p` rows (first kept).

    Args:
        theta_p: `M x P` physical parameters.
        outputs: `M x L' x n_x` model outputs [µε].

    Returns:
        ``(theta_p, outputs)`` restricted to the usable rows, float64 tensors.
    """
    theta = torch.as_tensor(np.asarray(theta_p), dtype=torch.float64)
    out = torch.as_tensor(np.asarray(outputs), dtype=torch.float64)
    keep = torch.isfinite(out.reshape(out.shape[0], -1)).all(-1) & torch.isfinite(theta).all(-1)
    theta, out = theta[keep], out[keep]
    _, first = np.unique(theta.numpy().round(12), axis=0, return_index=True)
    index = torch.as_tensor(np.sort(first), dtype=torch.long)
    return theta[index], out[index]


def fit_emulator(
    theta_p: object,
    outputs: object,
    x: object,
    loads: object,
    *,
    names: Sequence[str] | None = None,
    transform: dict[str, Any] | None = None,
    kernel: str = "rbf",
    min_noise: float = 1e-10,
    lengthscales: tuple[float, ...] = (0.2, 0.5, 1.0),
    max_iter: int = 200,
) -> Surrogate:
    """Fit the shared-kernel GP surrogate to stored outputs, without calling any model.

    Args:
        theta_p: `M x P` physical parameters at which the model was evaluated.
        outputs: `M x L' x n_x` model outputs there [µε]; non-finite and repeated rows are
            dropped.
        x: `n_x` positions [m] of the outputs.
        loads: `L'` load cases [m] of the outputs.
        names: `P` physical parameter names (for the surrogate's repr).
        transform: keywords of :meth:`ResponseTransform.fit` (default :data:`PLAIN`).
        kernel, min_noise, lengthscales, max_iter: as :func:`torchshm.fit_surrogate`.

    Returns:
        A :class:`~torchshm.surrogate.Surrogate` (``predict`` gives mean and variance
        `... x L' x n_x`).

    Raises:
        ValueError: with fewer than `P + 2` usable evaluations.
    """
    theta, out = clean_design(theta_p, outputs)
    if theta.shape[0] < theta.shape[1] + 2:
        raise ValueError(
            f"emulator: only {theta.shape[0]} distinct finite stored evaluations; at least "
            f"{theta.shape[1] + 2} are needed"
        )
    options = dict(PLAIN if transform is None else transform)
    scaling = ResponseTransform.fit(theta, out.reshape(theta.shape[0], -1), standardize="output", **options)
    gp = build_gp(scaling, theta, out, kernel, min_noise)
    targets = gp.train_targets  # m x N
    fitted = gp
    if targets.shape[0] > targets.shape[1]:  # more outputs than runs: fit on N compressed ones
        fitted = SharedKernelGP(gp.train_inputs[0], compressed_targets(targets), kernel, min_noise)
    with warnings.catch_warnings():
        # outputs of smooth models are nearly noise-free: a jitter on the diagonal is expected
        warnings.simplefilter("ignore", NumericalWarning)
        log_ml = fitted.fit(lengthscales=lengthscales, max_iter=max_iter)
        if fitted is not gp:
            gp.load_state_dict(fitted.state_dict())
            gp.freeze()
    names = tuple(names or [f"theta_p[{i}]" for i in range(theta.shape[1])])
    metadata = {"log_marginal_likelihood": log_ml, "purpose": "posterior predictive emulator"}
    return Surrogate(gp, scaling, torch.as_tensor(x), torch.as_tensor(loads), names,
                     "stored-evaluations", theta, out, metadata)


def compressed_targets(targets: Tensor) -> Tensor:
    """`N x N` targets ``Y'`` with ``Y'ᵀY' / N = YᵀY / m`` for `m x N` targets ``Y``: the same
    mean log marginal likelihood per output for every kernel and noise (module docstring).

    ``Y' = sqrt(N / m) diag(sqrt(w)) Vᵀ`` from the eigendecomposition ``YᵀY = V diag(w) Vᵀ``.
    """
    m, N = targets.shape
    w, V = torch.linalg.eigh(targets.mT @ targets)
    return (V * (w.clamp_min(0.0) * (N / m)).sqrt()).mT.contiguous()
