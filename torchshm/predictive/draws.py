"""Draws of unobserved strains given model responses and statistical parameters (Eq. 15, 21).

For one posterior sample with model response ``eta`` (`L' x n`) and discrepancy parameters
``sigma_a``, ``length``, each load case is drawn independently from::

    y_l ~ N(eta_l, sigma_m**2 diag(eta_l)**2 + K + sigma_e**2 I)

as ``eta_l + sigma_m * eta_l * z1 + chol(K + sigma_e**2 I) @ z2`` with standard normal ``z1``,
``z2``. The discrepancy is drawn per load case, as the likelihood treats load cases as
independent (block-diagonal covariance).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels import Kernel, get_kernel
from torchshm.kernels.base import as_float64, distances
from torchshm.likelihood.cholesky import cholesky_with_jitter

#: largest covariance batch [bytes] built and factorised at once (small batches stay in cache)
CHUNK_BYTES = 2**21


def predictive_draws(
    eta: object,
    x: object,
    kernel: str | Kernel,
    sigma_a: object,
    length: object | None,
    sigma_m: float,
    sigma_e: float,
    generator: torch.Generator,
) -> Tensor:
    """One draw of unobserved strains per model response (paper, Eq. 15 with Eq. 21).

    The standard normal variates are drawn from ``generator`` in a fixed order (first the
    multiplicative term, `N x L' x n`, then the correlated term, `N x L' x n`), so two calls with
    equally seeded generators use the same noise whatever ``eta`` is.

    Args:
        eta: `N x L' x n` model responses [µε].
        x: `n` positions [m].
        kernel: discrepancy kernel, a name or a :class:`~torchshm.kernels.Kernel`.
        sigma_a: `N` discrepancy scales [µε].
        length: `N` correlation lengths [m]; ignored (may be ``None``) without a length.
        sigma_m: standard deviation of the multiplicative model error (dimensionless).
        sigma_e: standard deviation of the measurement noise [µε].
        generator: source of the standard normal variates.

    Returns:
        `N x L' x n` draws [µε].
    """
    kern = get_kernel(kernel)
    eta, x, sigma_a = as_float64(eta), as_float64(x), as_float64(sigma_a)
    n_draws, _, n = eta.shape
    z1 = torch.randn(eta.shape, generator=generator, dtype=torch.float64)
    z2 = torch.randn(eta.shape, generator=generator, dtype=torch.float64)
    out = eta + sigma_m * eta * z1
    if kern.is_diagonal:
        sd = (kern.diag(x, sigma_a=sigma_a) + sigma_e**2).sqrt()  # N x n
        return out + sd[:, None, :] * z2
    ell = as_float64(length)
    d = distances(x, x)
    size = max(1, CHUNK_BYTES // (n * n * 8))
    for start in range(0, n_draws, size):
        part = slice(start, start + size)
        cov = kern.correlation(d, ell[part, None, None]) * sigma_a[part, None, None].square()
        cov.diagonal(dim1=-2, dim2=-1).add_(sigma_e**2)
        chol, failed = cholesky_with_jitter(cov)
        if bool(failed.any()):
            raise ValueError("predictive draws: a discrepancy covariance is not positive definite")
        out[part] += torch.matmul(chol, z2[part].mT).mT
    return out


def equal_tailed(samples: Tensor, level: float = 0.95) -> tuple[Tensor, Tensor, Tensor]:
    """Mean and equal-tailed interval of draws along the first dimension.

    Args:
        samples: `N x ...` draws.
        level: probability content of the interval.

    Returns:
        ``(mean, lower, upper)``, each of shape `...`.
    """
    tail = (1.0 - level) / 2.0
    lower, upper = np.quantile(samples.numpy(), [tail, 1.0 - tail], axis=0)
    return samples.mean(0), torch.from_numpy(lower), torch.from_numpy(upper)
