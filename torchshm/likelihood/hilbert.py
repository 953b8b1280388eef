"""The reduced-rank (Hilbert-space) form of Eq. (21) along a line, for a kernel with a Gaussian
spectral density (``squared_exponential``).

The kernel, which has no state-space form, is expanded in the eigenfunctions of the Laplacian
on an interval ``[c - L*, c + L*]`` that holds the positions with a margin (Solin & Särkkä 2020,
*Hilbert space methods for reduced-rank Gaussian process regression*, Stat. Comput. 30)::

    k(x, x') ≈ sum_j S(omega_j) phi_j(x) phi_j(x'),
    phi_j(x) = sin(pi j (x - c + L*) / (2 L*)) / sqrt(L*),   omega_j = pi j / (2 L*),

``S`` the kernel's spectral density. With ``Psi = Phi diag(S)^½`` (`n x m`) and the diagonal
``D = sigma_e² + sigma_m² eta² (+ extra)``, the covariance ``D + Psi Psiᵀ`` has, by Woodbury and
the determinant lemma, the log density::

    -½ [rᵀ D⁻¹ r - |C⁻¹ Psiᵀ D⁻¹ r|² + sum log D + 2 sum log diag C + n log 2π],
    C Cᵀ = I + Psiᵀ D⁻¹ Psi   (m x m),

in O(n m²) time instead of the dense form's O(n³). Two choices bound its error, both in units
of the kernel's Gaussian spread ``s`` (``s = length / sqrt(2)`` for ``exp(-(d/length)²)``):
the margin ``L* - (half the positions' range) = MARGIN s`` (the Dirichlet boundary's image
term, ``exp(-2 MARGIN²)`` of the variance) and the highest frequency ``omega_m s >= KAPPA``
(the spectrum's tail, ``erfc(KAPPA / sqrt(2))``). With ``KAPPA = 8`` and ``MARGIN = 4`` the log
density agrees with the dense Cholesky's to 1e-5 nat at 458 points and 2e-5 at 1,000, for
lengths of 0.025 to 2 times the line and noise down to 1/3000 of ``sigma_a``
(``tests/likelihood/test_hilbert.py``, ``docs/likelihood.md``). Rows whose basis would be
larger than :data:`SHARE` of the points (short lengths) are left to the dense form by the caller
(:func:`fits`). Plain torch: differentiable by autograd (to any order), on CPU or CUDA.
"""

from __future__ import annotations

import math
from typing import Any

import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.kernels.base import MIN_LENGTH
from torchshm.likelihood.constants import LOG_2PI

#: highest frequency of the basis times the kernel's spread (the spectrum's tail left out:
#: erfc(8 / sqrt(2)) ≈ 1e-15 of the variance)
KAPPA = 8.0
#: margin between the positions and the interval's ends, in the kernel's spreads
MARGIN = 4.0
#: largest basis, as a share of the points, for which this form is used (measured against the
#: dense form with its closed-form gradient: docs/benchmarks.md)
SHARE = 0.4


def applies(kern: Kernel) -> bool:
    """Whether ``kern`` has the Gaussian spectral density this form expands."""
    return getattr(kern, "gaussian_spread", None) is not None


def _basis(half: float, longest: Any, shortest: Any) -> tuple[Any, Any]:
    """The interval's half-width ``L*`` [m] and the (fractional) number of sines that positions
    of half-range ``half`` [m] call for, for spreads ``longest`` (the margin) and ``shortest``
    (the highest frequency): floats or tensors."""
    reach = half + MARGIN * longest
    return reach, 2.0 * KAPPA * reach / (math.pi * shortest)


def sizes(x: Tensor, kern: Kernel, length: Tensor) -> Tensor:
    """The basis size `B` (int64) each row's own length calls for at positions ``x`` (`n`)."""
    spread = kern.gaussian_spread * length.clamp_min(MIN_LENGTH)
    _, size = _basis(0.5 * float(x.max() - x.min()), spread, spread)
    size = torch.where(torch.isfinite(size), size, 2.0**62)  # a NaN or infinite length: never fits
    return torch.ceil(size.clamp_max(2.0**62)).to(torch.int64)


def fits(x: Tensor, kern: Kernel, length: Tensor) -> Tensor:
    """`B` booleans: the rows this form takes (basis at most :data:`SHARE` of the points)."""
    return sizes(x, kern, length.detach()) <= SHARE * x.shape[0]


def log_density(resid: Tensor, noise: Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor,
                length: Tensor, shared: bool = False) -> Tensor:
    """Log densities `B` of the residuals under Eq. (21), summed over load cases.

    Rows are taken in octaves of their length, each octave with one basis (the margin of its
    longest length, the frequencies of its shortest).

    Args:
        resid: `B x L x n` residuals ``y - eta`` [µε] at positions ``x`` (`n`, any order) [m].
        noise: `B x L x n` diagonal ``D`` [µε²], > 0 (with ``shared``, equal over load cases).
        kern: a kernel for which :func:`applies`.
        sigma_a: `B` scales [µε]; length: `B` correlation lengths [m].
        shared: whether ``noise`` is the same for every load case (one factor per row).
    """
    ell = length.clamp_min(MIN_LENGTH)
    octave = torch.floor(torch.log2(ell.detach()))
    out = resid.new_empty(resid.shape[0])
    for level in torch.unique(octave):
        rows = octave == level
        out[rows] = _log_density(resid[rows], noise[rows], x, kern, sigma_a[rows], ell[rows], shared)
    return out


def _log_density(resid: Tensor, noise: Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor,
                 length: Tensor, shared: bool) -> Tensor:
    """:func:`log_density` for rows sharing one basis."""
    spread = kern.gaussian_spread * length.detach()
    centre, half = 0.5 * float(x.max() + x.min()), 0.5 * float(x.max() - x.min())
    reach, size = _basis(half, float(spread.max()), float(spread.min()))
    m = math.ceil(size)
    omega = (math.pi / (2.0 * reach)) * torch.arange(1, m + 1, dtype=x.dtype, device=x.device)
    phi = torch.sin(omega * (x - centre + reach)[:, None]) / math.sqrt(reach)  # n x m
    # sigma_a S^½ (B x m): not (sigma_a² S)^½, whose gradient is not finite at sigma_a = 0
    weight = sigma_a[:, None] * kern.spectral_density(omega, length[:, None]).sqrt()
    root = (noise[:, :1] if shared else noise).sqrt()  # B x L' x n
    w = phi * weight[:, None, None, :] / root[..., None]  # B x L' x n x m
    inner = w.mT @ w
    inner.diagonal(dim1=-2, dim2=-1).add_(1.0)
    chol = torch.linalg.cholesky(inner)  # B x L' x m x m, eigenvalues >= 1
    scaled = resid / (root if not shared else root.expand_as(resid))
    proj = torch.linalg.solve_triangular(chol, w.mT @ scaled[..., None], upper=False)[..., 0]
    quad = scaled.square().sum(-1) - proj.square().sum(-1)  # B x L
    logdet = noise.log().sum(-1) + 2.0 * chol.diagonal(dim1=-2, dim2=-1).log().sum(-1)
    return -0.5 * (quad + logdet + resid.shape[-1] * LOG_2PI).sum(-1)
