"""Fit a GP surrogate of a forward model on a design: evaluate, transform, fit, wrap."""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Literal, Sequence

import gpytorch
import numpy as np
import torch

from torchshm.arrays import as_float64
from torchshm.forward.protocol import ForwardModel, model_identity
from torchshm.storage import EvaluationStore, evaluate
from torchshm.surrogate.field import fit_field
from torchshm.surrogate.surrogate import Surrogate
from torchshm.surrogate.transforms import ResponseTransform, transform_of

#: a transform keyword left to the model (its ``surrogate_transform``, else plain scaling)
FromModel = Literal["model"]


def fit_surrogate(
    model: ForwardModel,
    theta_p: object,
    store: EvaluationStore | str | Path | None = None,
    n_jobs: int = 1,
    *,
    kernel: str = "rbf",
    log_inputs: tuple[int, ...] | FromModel = "model",
    modulus: int | None | FromModel = "model",
    relative_to_modulus: tuple[int, ...] | FromModel = "model",
    standardize: str = "output",
    names: Sequence[str] | None = None,
    min_noise: float = 1e-10,
    lengthscales: tuple[float, ...] = (0.2, 0.5, 1.0),
    max_iter: int = 200,
) -> Surrogate:
    """Fit a GP surrogate with shared hyperparameters to a forward model on a design.

    The design is evaluated through :func:`torchshm.storage.evaluate` (through ``store`` when
    given, so an interrupted fit resumes without repeating a finished run). Failed runs are
    left out with a warning naming them. All `L x n` outputs share one kernel, fitted by the
    exact marginal likelihood (see :mod:`torchshm.surrogate.gp`) through the library's one fit
    recipe, :func:`torchshm.surrogate.field.fit_field`.

    The transform keywords left at ``"model"`` come from the model's ``surrogate_transform``
    attribute (bridge 705 declares its elastic structure there), or are plain scaling
    (``log_inputs=(), modulus=None, relative_to_modulus=()``) for a model without one.

    Args:
        model: forward model, ``model(theta_p) -> ... x L x n`` with ``x`` and ``loads``.
        theta_p: `N x P` design [model units], e.g. a :func:`grid_design`.
        store: an evaluation store or its path; None keeps nothing.
        n_jobs: local worker processes for the model runs (-1: every core).
        kernel: "rbf" or "matern52" (ARD, with an output scale), or either with ``_additive``
            (plus one kernel per input: :data:`~torchshm.surrogate.gp.SURROGATE_KERNELS`).
        log_inputs: columns of θp the GP sees as log10, or ``"model"``.
        modulus: column of θp that is an elastic modulus (strains ∝ 1 / modulus), None, or
            ``"model"``.
        relative_to_modulus: columns holding log10 of a stiffness that does not scale with
            the modulus (the GP sees them minus log10 of the modulus), or ``"model"``.
        standardize: "output" (a scale per output) or "global" (one scale).
        names: parameter names; default ``model.names`` or ``theta_p[i]``.
        min_noise: lower bound of the GP noise variance (standardised units).
        lengthscales: initial lengthscales of the marginal-likelihood restarts.
        max_iter: L-BFGS iterations per restart.

    Returns:
        The fitted :class:`Surrogate`.

    Raises:
        ValueError: if fewer than P + 2 design points evaluate successfully, or on a bad
            transform option.
    """
    start = time.perf_counter()
    theta, outputs = _evaluate_design(model, theta_p, store, n_jobs)
    given = {"log_inputs": log_inputs, "modulus": modulus,
             "relative_to_modulus": relative_to_modulus}
    options = {**transform_of(model), **{k: v for k, v in given.items() if v != "model"}}
    transform = ResponseTransform.fit(
        theta, outputs.reshape(outputs.shape[0], -1), standardize=standardize, **options)
    fit = fit_field(theta, outputs, transform=transform, kernel=kernel, min_noise=min_noise,
                    lengthscales=lengthscales, max_iter=max_iter, what="fit_surrogate")
    gp, log_ml = fit.gp, fit.log_marginal_likelihood
    metadata = {
        "log_marginal_likelihood": log_ml, "standardize": standardize,
        "fit_seconds": time.perf_counter() - start,
        "lengthscale": gp.scale_kernels()[0].base_kernel.lengthscale.reshape(-1).tolist(),
        "outputscale": float(gp.scale_kernels()[0].outputscale),
        "noise": float(gp.likelihood.noise), "torch": str(torch.__version__),
        "gpytorch": str(gpytorch.__version__),
    }
    default = getattr(model, "names", None) or [f"theta_p[{i}]" for i in range(theta.shape[1])]
    return Surrogate(gp, transform, as_float64(model.x), as_float64(model.loads),
                     tuple(names or default), model_identity(model), theta, outputs, metadata)


def _evaluate_design(model: ForwardModel, theta_p: object, store: EvaluationStore | str | Path | None,
                     n_jobs: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Successful, distinct design rows `N x P` and their strains `N x L x n` [µε]."""
    result = evaluate(model, theta_p, store=store, n_jobs=n_jobs)
    if not result.ok.all():
        failed = [f"row {i} θp={result.theta_p[i].tolist()}: {result.errors[i]}"
                  for i in np.flatnonzero(~result.ok)]
        warnings.warn(f"fit_surrogate: {len(failed)} of {len(result.ok)} design evaluations "
                      f"failed and are left out: " + "; ".join(failed), stacklevel=3)
    _, index = np.unique(result.theta_p[result.ok], axis=0, return_index=True)
    index = np.sort(index)
    theta, outputs = result.theta_p[result.ok][index], result.outputs[result.ok][index]
    if theta.shape[0] < theta.shape[1] + 2:
        raise ValueError(f"fit_surrogate: only {theta.shape[0]} distinct successful design "
                         f"evaluations; at least {theta.shape[1] + 2} are needed")
    return torch.as_tensor(theta, dtype=torch.float64), torch.as_tensor(outputs,
                                                                        dtype=torch.float64)
