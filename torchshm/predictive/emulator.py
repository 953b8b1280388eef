"""Gaussian-process emulator of stored model outputs (paper, Sec. 2.4.1 and Sec. 4).

Inference already evaluated the forward model at a few hundred physical parameter vectors
`theta_p`, for *all* its load cases. The emulator is the library's FE-response surrogate
(:mod:`torchshm.surrogate`: zero-mean GPs of all outputs with one shared kernel, fitted by the
exact marginal likelihood) trained on those stored pairs, restricted to the prediction load
cases and positions. Nothing here calls a forward model: the emulator sees arrays only.

Input and output transforms (see :mod:`torchshm.surrogate.transforms`) are chosen by
:func:`transform_options`: the surrogate's own when the problem's model is a surrogate, the
model's ``surrogate_transform`` attribute when it declares one, plain scaling otherwise.

The fit is the library's one recipe for field GPs, :func:`torchshm.surrogate.field.fit_field`
(failed and repeated runs dropped, transforms, output compression at dense sensing: the
hyperparameters fitted on ``N`` compressed outputs with the same marginal likelihood).
"""

from __future__ import annotations

from typing import Any, Sequence

import torch

from torchshm.forward.protocol import ForwardModel
from torchshm.surrogate import Surrogate
from torchshm.surrogate.field import clean_design, compressed_targets, fit_field
from torchshm.surrogate.transforms import PLAIN, transform_of

__all__ = ["PLAIN", "clean_design", "compressed_targets", "fit_emulator", "transform_options"]


def transform_options(model: ForwardModel) -> dict[str, Any]:
    """Transform keywords suited to a forward model (see the module docstring)."""
    return transform_of(model)


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
    fit = fit_field(theta_p, outputs, transform=transform, kernel=kernel, min_noise=min_noise,
                    lengthscales=lengthscales, max_iter=max_iter, what="emulator")
    names = tuple(names or [f"theta_p[{i}]" for i in range(fit.theta_p.shape[1])])
    metadata = {"log_marginal_likelihood": fit.log_marginal_likelihood,
                "purpose": "posterior predictive emulator"}
    return Surrogate(fit.gp, fit.transform, torch.as_tensor(x), torch.as_tensor(loads), names,
                     "stored-evaluations", fit.theta_p, fit.outputs, metadata)
