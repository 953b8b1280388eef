"""The chance that a point of the box reaches the exploration's level, read to second order.

The exploration (:mod:`.explore`) first bounds the emulated log joint at a Sobol point by
``μ + κ s``, ``s`` the first-order sd of the log-likelihood that the emulator's error causes
there. Far from the data that bound is loose: the error moves the strains, and Eq. (21) pays
for a moved field quadratically, so the log-likelihood's upper tail is much shorter than a
Gaussian of sd ``s`` has (on ``seventh3_p6``, of hundreds of points a round that the first-order
bound kept open, none had one of 64 exact draws at the level; ``docs/benchmarks.md``).

In the error model of the method (:meth:`~.likelihood.EmulatedLogJoint.error_variance`), the
error field is ``δ = sqrt(v) ⊙ (E z)``, ``E`` the runs' field shapes and ``z`` `N` standard
normals. With σm = 0, Eq. (21) is a concave quadratic in ``z``::

    ℓ(z) = ℓ0 + aᵀ z - ½ zᵀ H z,    a = Eᵀ (sqrt(v) ⊙ ∂ℓ/∂η),   H ⪰ 0.

With ``u = a / |a|``, ``α = uᵀ z`` (a standard normal) and ``β = (H u)ᵀ z``, the Cauchy-Schwarz
inequality in ``H``'s inner product, ``(uᵀ H z)² <= (uᵀ H u)(zᵀ H z)``, gives for every ``z``::

    ℓ(z) <= ℓ0 + |a| α - β² / (2 uᵀ H u),

a bound in two correlated normals whose upper tail is one quadrature (:func:`quadratic_tail`).
``H u`` is the change of the gradient along the error field ``δ(u)`` (one more gradient per
point: exact for the quadratic). With σm > 0 the covariance moves with the strains and Eq. (21)
is not exactly quadratic: the bound is then a second-order reading, not a bound; measured
against exact draws in ``scripts/trace_exploration.py`` (its ``missed`` column).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch
from scipy.stats import norm

if TYPE_CHECKING:
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

#: quadrature nodes over α (12 sds from where the first-order bound reaches the level)
N_ALPHA = 2000
#: sds of α beyond the first-order crossing that the quadrature covers
SPAN = 12.0


def quadratic_tail(slope: np.ndarray, curvature: np.ndarray, cross: np.ndarray,
                   gap: np.ndarray) -> np.ndarray:
    """``P(|a| α - β² / (2 c) >= gap)`` for standard normal ``α`` and ``β`` of sd ``|h|`` with
    ``cov(α, β) = c``, each `U` (the module's bound).

    Args:
        slope: ``|a|`` [nats per unit α], >= 0.
        curvature: ``c = uᵀ H u`` [nats], >= 0 (0: the first-order tail ``Φ(-gap / |a|)``).
        cross: ``|h| = |H u|`` [nats], >= ``c``.
        gap: nats between the plug-in value and the level (may be negative).
    """
    slope = np.maximum(np.asarray(slope, dtype=np.float64), 1e-300)
    c = np.maximum(np.asarray(curvature, dtype=np.float64), 0.0)
    hn = np.maximum(np.asarray(cross, dtype=np.float64), np.maximum(c, 1e-300))
    given = np.asarray(gap, dtype=np.float64)
    gap = np.where(np.isfinite(given), given, 0.0)  # the infinite ones are set at the end
    first = norm.sf(gap / slope)
    rho = np.clip(c / hn, 0.0, 1.0)
    other = np.sqrt(np.clip(1.0 - rho**2, 0.0, None))
    start = np.clip(gap / slope, -SPAN, SPAN)  # α below it cannot reach the level
    alpha = start[:, None] + np.linspace(0.0, SPAN, N_ALPHA)[None, :]
    room = 2.0 * c[:, None] * (slope[:, None] * alpha - gap[:, None])  # β² must stay below it
    half = np.sqrt(np.clip(room, 0.0, None)) / hn[:, None]
    centre = rho[:, None] * alpha  # β / |h| = ρ α + sqrt(1 - ρ²) w
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = np.where(other[:, None] > 1e-9,
                          norm.cdf((half - centre) / other[:, None]) - norm.cdf((-half - centre) / other[:, None]),
                          (np.abs(centre) <= half).astype(float))
    inner = np.where(room >= 0.0, spread, 0.0)
    second = np.trapezoid(norm.pdf(alpha) * inner, alpha, axis=1) + norm.sf(start + SPAN)
    chance = np.where(c > 1e-12 * slope**2, second, first)
    return np.where(np.isfinite(given), np.clip(chance, 0.0, 1.0), np.where(given < 0, 1.0, 0.0))


def reach_chance(log_joint: EmulatedLogJoint, rows: np.ndarray, level: float,
                 calibration: float = 1.0) -> np.ndarray:
    """`U` chances (module docstring) that the log joint at rows `U x D` reaches ``level``
    [nats] under the emulator's error model, its variance times ``calibration**2`` (the
    exploration's record, >= 1) on top of ``log_joint``'s own inflation."""
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

    rows = np.atleast_2d(np.asarray(rows, dtype=np.float64))
    if rows.shape[0] == 0:
        return np.zeros(0)
    scaled = EmulatedLogJoint(log_joint.problem, log_joint.emulator,
                              log_joint.inflation * max(1.0, calibration) ** 2)
    mean, var, theta = scaled.parts(rows)
    prior = np.asarray(scaled.problem.log_prior(rows), dtype=np.float64).reshape(-1)
    basis = scaled.emulator.error_basis  # m x N
    sv = var.sqrt() * scaled.valid.to(var.dtype)
    none = torch.zeros_like(var)
    value, grad = scaled.gradient(mean, none, theta)
    a = (sv * torch.nan_to_num(grad)).flatten(1) @ basis  # U x N
    slope = a.norm(dim=-1)
    u = a / slope.clamp_min(1e-300)[:, None]
    _, moved = scaled.gradient(mean + (sv.flatten(1) * (u @ basis.mT)).reshape(mean.shape), none, theta)
    h = (sv * torch.nan_to_num(grad - moved)).flatten(1) @ basis  # H u
    gap = level - (np.where(np.isfinite(value), value, -np.inf) + prior)
    return quadratic_tail(slope.numpy(), (u * h).sum(-1).numpy(), h.norm(dim=-1).numpy(), gap)


__all__ = ["quadratic_tail", "reach_chance"]
