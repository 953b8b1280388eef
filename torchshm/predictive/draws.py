"""Draws of unobserved strains given model responses and statistical parameters (Eq. 15, 21).

For one posterior sample with model response ``eta`` (`L' x n`) and discrepancy parameters
``sigma_a``, ``length``, each load case is drawn independently from::

    y_l ~ N(eta_l, sigma_m**2 diag(eta_l)**2 + K + sigma_e**2 I)

by :meth:`torchshm.likelihood.marginal.Eq21.sample`, the distribution the likelihood uses:
``eta_l + sigma_m * eta_l * z1`` plus the discrepancy and noise, drawn through
``chol(K + sigma_e**2 I)`` (dense) or, for the Markov kernels at
:data:`~torchshm.likelihood.marginal.STATE_SPACE_FROM` points and more, through the kernel's
state-space form in O(n) (kernel ``separable_exponential`` on a regular grid: the AR(1)
recursion along each axis, :func:`torchshm.likelihood.lattice.sample`). The discrepancy is
drawn per load case, as the likelihood treats load cases as independent (block-diagonal
covariance).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels import Kernel, get_kernel
from torchshm.kernels.base import as_float64
from torchshm.likelihood.marginal import Eq21
from torchshm.likelihood.statespace import BATCH_STATE_SPACE_FROM, is_markov

#: 1-D lines of a Markov kernel from this many points are drawn by the O(n) state space
STATE_SPACE_FROM = BATCH_STATE_SPACE_FROM
#: bytes of the float64 draws of the points summarised at once (:func:`equal_tailed`)
SUMMARY_CHUNK_BYTES = 2**26

if TYPE_CHECKING:
    from torchshm.predictive.view import PredictionView


def predictive_draws(
    eta: object,
    x: object,
    kernel: str | Kernel,
    sigma_a: object,
    length: object | None,
    sigma_m: float | Tensor,
    sigma_e: float | Tensor,
    generator: torch.Generator,
    method: str = "auto",
) -> Tensor:
    """One draw of unobserved strains per model response (paper, Eq. 15 with Eq. 21).

    The standard normal variates are drawn from ``generator`` in a fixed order (see
    :meth:`~torchshm.likelihood.marginal.Eq21.sample`), so two calls with equally seeded
    generators use the same noise whatever ``eta`` is.

    Args:
        eta: `N x L' x n` model responses [µε].
        x: `n` positions [m].
        kernel: discrepancy kernel, a name or a :class:`~torchshm.kernels.Kernel`.
        sigma_a: `N` discrepancy scales [µε].
        length: `N` correlation lengths [m]; ignored (may be ``None``) without a length.
        sigma_m: standard deviation of the multiplicative model error (dimensionless).
        sigma_e: standard deviation of the measurement noise [µε].
        generator: source of the standard normal variates.
        method: ``"auto"``, ``"dense"`` or ``"state_space"`` (as for the likelihood).

    Returns:
        `N x L' x n` draws [µε].
    """
    kern = get_kernel(kernel)
    eta, x, sigma_a = as_float64(eta), as_float64(x), as_float64(sigma_a)
    ell = as_float64(0.0 if length is None or not kern.has_length else length).expand(sigma_a.shape)
    positive = bool(torch.all(torch.as_tensor(sigma_e) > 0))
    # the lattice draws (AR(1) recursions on the grid) need no noise; the state space does
    form = method if method != "auto" or positive or getattr(kern, "form", None) == "lattice" else "dense"
    return Eq21(eta, x, kern, sigma_a, ell, sigma_m, sigma_e, form).sample(generator)


def line_draws(
    view: PredictionView,
    eta: Tensor,
    kernel: str | Kernel,
    sigma_a: Tensor,
    length: Tensor | None,
    sigma_m: float | Tensor,
    generator: torch.Generator,
    sigma_e_scale: Tensor | None = None,
) -> Tensor:
    """Predictive draws line by line: each line of ``view`` is its own Gaussian of Eq. (21).

    The lines are drawn in order from ``generator`` by :func:`predictive_draws`, each with its
    own noise and discrepancy group; one line is exactly one call of :func:`predictive_draws`.

    Args:
        view: the points and lines (:func:`~torchshm.predictive.view.prediction_view`).
        eta: `N x L' x n` model responses at the points [µε].
        kernel: the discrepancy kernel.
        sigma_a: `N x G` discrepancy scales [µε], one column per group.
        length: `N x G` correlation lengths [m], or ``None`` for a kernel without length.
        sigma_m: multiplicative model error (dimensionless): a number or `N` inferred values.
        generator: source of the standard normal variates.
        sigma_e_scale: `N` factors on every line's noise sd (an inferred σe), or None.

    Returns:
        `N x L' x n` draws [µε].
    """
    def noise(part: object) -> float | Tensor:
        return part.sigma_e if sigma_e_scale is None else part.sigma_e * sigma_e_scale  # type: ignore[attr-defined]

    kern = get_kernel(kernel)

    def form(x: Tensor, part: object) -> str:
        """The O(n) state space for 1-D lines of a Markov kernel from STATE_SPACE_FROM points
        (a batch of draws gains from it far below the likelihood's one-vector threshold)."""
        markov = x.ndim == 1 and is_markov(kern) and part.sigma_e > 0  # type: ignore[attr-defined]
        return "state_space" if markov and x.shape[0] >= STATE_SPACE_FROM else "auto"

    if len(view.parts) == 1 and view.parts[0].points.numel() == eta.shape[-1]:
        part = view.parts[0]
        return predictive_draws(eta, view.x, kernel, sigma_a[:, part.group],
                                None if length is None else length[:, part.group], sigma_m,
                                noise(part), generator, form(view.x, part))
    out = torch.empty_like(eta)
    for part in view.parts:
        out[..., part.points] = predictive_draws(
            eta[..., part.points], view.x[part.points], kernel, sigma_a[:, part.group],
            None if length is None else length[:, part.group], sigma_m, noise(part), generator,
            form(view.x[part.points], part),
        )
    return out


def equal_tailed(samples: Tensor, level: float = 0.95,
                 chunk_bytes: int | None = None) -> tuple[Tensor, Tensor, Tensor]:
    """Mean and equal-tailed interval of draws along the first dimension.

    The quantiles are taken over ``chunk_bytes`` of the draws' points at a time (the same numbers
    as over all at once, without a copy of every draw); float32 draws give float64 summaries
    (the mean too is summed in float64 by chunks of points).

    Args:
        samples: `N x ...` draws (float64 or float32).
        level: probability content of the interval.
        chunk_bytes: bytes of float64 draws summarised at once (default
            :data:`SUMMARY_CHUNK_BYTES`).

    Returns:
        ``(mean, lower, upper)``, each of shape `...`, float64.
    """
    tail = (1.0 - level) / 2.0
    chunk_bytes = SUMMARY_CHUNK_BYTES if chunk_bytes is None else chunk_bytes
    flat = samples.reshape(samples.shape[0], -1)
    wide = samples.dtype == torch.float64  # float32: the mean by chunks too (torch's would copy all)
    lower, upper, mean = (np.empty(flat.shape[1]) for _ in range(3))
    step = max(1, chunk_bytes // (8 * max(flat.shape[0], 1)))
    for start in range(0, flat.shape[1], step):
        block = flat[:, start:start + step].numpy().astype(np.float64, copy=False)
        lower[start:start + step], upper[start:start + step] = np.quantile(block, [tail, 1.0 - tail], axis=0)
        if not wide:
            mean[start:start + step] = block.mean(axis=0)
    shape = samples.shape[1:]
    return (samples.mean(0) if wide else torch.from_numpy(mean).reshape(shape),
            torch.from_numpy(lower).reshape(shape), torch.from_numpy(upper).reshape(shape))
