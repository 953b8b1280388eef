"""The exact sparse Gaussian of Eq. (21) for the separable exponential kernel on a regular grid.

With kernel ``separable_exponential`` (``sigma_a**2 exp(-|dx|/l - |dy|/l)``) the discrepancy on
the nodes of a regular grid of pitches ``(px, py)`` is a Gaussian Markov random field: along
each direction it is an AR(1) process with ``rho = exp(-pitch / l)``, whose precision ``Q1`` is
tridiagonal, and the field's precision is ``Q = Qx ⊗ Qy / sigma_a**2`` (nine entries a row).
The `n` points are `n` of the `N` nodes of the grid spanned by their bounding box (holes, masks
and repeated points allowed): ``A`` `n x N` selects them. With ``D = diag(noise)``::

    Σ = A Q⁻¹ Aᵀ + D,      M = Q + Aᵀ D⁻¹ A   (sparse, symmetric positive definite),
    log det Σ = Σ log d + log det M - log det Q,
    rᵀ Σ⁻¹ r = (r - A μ)ᵀ D⁻¹ (r - A μ) + μᵀ Q μ,      μ = M⁻¹ Aᵀ D⁻¹ r,

all exact (Woodbury); the quadratic form is written as a sum of two non-negative terms (the
posterior mean ``μ`` of the field), not as ``rᵀ D⁻¹ r - bᵀ M⁻¹ b``, which cancels when the
noise is far below ``sigma_a``. ``log det Q`` is analytic (``log det Q1 = -(m - 1) log(1 -
rho**2)`` at unit variance). ``M`` is factorised by SuperLU in a nested-dissection order of the
grid (:mod:`torchshm.likelihood.lattice_order`), once per distinct (``sigma_a``, ``l``, noise):
load cases with the same diagonal share it. NumPy/SciPy on the CPU; no gradients (the methods
that use this form do not need them). Draws: the AR(1) recursion along each axis (O(N)).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from scipy import sparse
from scipy.signal import lfilter
from scipy.sparse.linalg import splu
from torch import Tensor

from torchshm.likelihood.lattice_order import Grid, lattice, nested_dissection

__all__ = ["Grid", "lattice", "log_density", "sample"]

LOG_2PI = math.log(2.0 * math.pi)


def _ar1(size: int, pitch: float, length: float) -> tuple[sparse.csr_matrix, float, float]:
    """Precision `size x size` of a unit-variance AR(1) along one direction, its log
    determinant and ``rho``."""
    rho = math.exp(-pitch / max(length, 1e-300))
    if size == 1:
        return sparse.identity(1, format="csr"), 0.0, rho
    s = -math.expm1(-2.0 * pitch / max(length, 1e-300))  # 1 - rho**2, accurate near rho = 1
    main = np.full(size, (1.0 + rho * rho) / s)
    main[0] = main[-1] = 1.0 / s
    off = np.full(size - 1, -rho / s)
    q = sparse.diags([off, main, off], [-1, 0, 1], format="csr")
    return q, -(size - 1) * math.log(s), rho


def _precision(grid: Grid, sigma_a: float, length: float) -> tuple[sparse.csc_matrix, float]:
    """``Q`` `N x N` of the nodes in the grid's elimination order, and ``log det Q``."""
    (nx, ny), (px, py) = grid.shape, grid.pitch
    qx, ldx, _ = _ar1(nx, px, length)
    qy, ldy, _ = _ar1(ny, py, length)
    q = sparse.kron(qx, qy, format="coo")
    where = grid.position
    q = sparse.csc_matrix((q.data / sigma_a**2, (where[q.row], where[q.col])), shape=q.shape)
    return q, ny * ldx + nx * ldy - nx * ny * math.log(sigma_a**2)


def _factor(q: sparse.csc_matrix, weight: np.ndarray):
    """SuperLU of ``Q + diag(weight)`` (already in a fill-reducing order: kept as it is)."""
    m = (q + sparse.diags(weight)).tocsc()
    return splu(m, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})


def log_density(resid: Tensor, noise: Tensor, x: Tensor, sigma_a: Tensor, length: Tensor) -> Tensor:
    """Log densities `B` of the residuals `B x L x n` [µε], summed over load cases.

    Args:
        resid: ``y - eta`` `B x L x n` [µε]; noise: the diagonal `B x L x n` [µε²], > 0.
        x: `n x 2` coordinates [m] on one regular grid (:func:`lattice`).
        sigma_a: `B` scales [µε], > 0; length: `B` correlation lengths [m].

    Raises:
        ValueError: for points off a regular grid or a diagonal that is not positive.
    """
    grid = lattice(x)
    if grid is None:
        raise ValueError("the lattice form needs n x 2 points on one regular grid (holes allowed)")
    r, d = resid.detach().cpu().numpy(), noise.detach().cpu().numpy()
    if not bool((d > 0).all()):
        raise ValueError("the lattice form needs a positive diagonal of Eq. (21): sigma_e > 0")
    sa, ell = sigma_a.detach().cpu().numpy(), length.detach().cpu().numpy()
    col, nodes = grid.position[grid.node], grid.shape[0] * grid.shape[1]
    out = np.empty(r.shape[0])
    for b in range(r.shape[0]):
        if not (sa[b] > 0 and ell[b] >= 0):
            out[b] = np.nan
            continue
        q, log_det_q = _precision(grid, float(sa[b]), float(ell[b]))
        total = 0.0
        for load in range(r.shape[1]):
            if load == 0 or not np.array_equal(d[b, load], d[b, load - 1]):
                inv = 1.0 / d[b, load]
                lu = _factor(q, np.bincount(col, weights=inv, minlength=nodes))
                log_det = np.log(d[b, load]).sum() + np.log(np.abs(lu.U.diagonal())).sum() - log_det_q
            mu = lu.solve(np.bincount(col, weights=inv * r[b, load], minlength=nodes))
            e = r[b, load] - mu[col]
            quad = e @ (inv * e) + mu @ (q @ mu)
            total += -0.5 * (quad + log_det + r.shape[2] * LOG_2PI)
        out[b] = total
    return torch.as_tensor(out, dtype=resid.dtype, device=resid.device)


def sample(x: Tensor, sigma_a: Tensor, length: Tensor, n_loads: int, generator: torch.Generator) -> Tensor:
    """Exact draws `B x L x n` [µε] of the discrepancy at the points ``x`` `n x 2` [m].

    Per parameter vector in turn, `L x Nx x Ny` standard normals from ``generator`` are carried
    through the AR(1) recursion ``g_i = rho g_(i-1) + sqrt(1 - rho**2) z_i`` (``g_0 = z_0``) along
    x, then along y, and scaled by ``sigma_a``: covariance ``sigma_a**2 exp(-|dx|/l - |dy|/l)``.

    Raises:
        ValueError: for points off a regular grid.
    """
    grid = lattice(x)
    if grid is None:
        raise ValueError("the lattice form needs n x 2 points on one regular grid (holes allowed)")
    out = []
    for b in range(sigma_a.shape[0]):
        z = torch.randn(n_loads, *grid.shape, generator=generator, dtype=torch.float64).numpy()
        for axis, pitch in ((1, grid.pitch[0]), (2, grid.pitch[1])):
            z = _ar1_filter(z, axis, pitch, float(length[b]))
        out.append(torch.as_tensor(float(sigma_a[b]) * z[:, grid.ix, grid.iy]))
    return torch.stack(out).to(x.device)


def _ar1_filter(z: np.ndarray, axis: int, pitch: float, length: float) -> np.ndarray:
    """Unit-variance AR(1) of step ``rho = exp(-pitch / length)`` driven by ``z`` along ``axis``."""
    if z.shape[axis] == 1:
        return z
    rho = math.exp(-pitch / max(length, 1e-300))
    s = math.sqrt(-math.expm1(-2.0 * pitch / max(length, 1e-300)))
    first = [slice(None)] * z.ndim
    first[axis] = slice(0, 1)
    z = z.copy()
    z[tuple(first)] /= s  # so that the filter's first output is z_0 itself
    return lfilter([s], [1.0, -rho], z, axis=axis)
