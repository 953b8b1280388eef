"""The exact sparse Gaussian of Eq. (21) for the separable exponential kernel on a regular grid.

With kernel ``separable_exponential`` (``sigma_a**2 exp(-|dx|/l - |dy|/l)``) the discrepancy on
the nodes of a regular grid of pitches ``(px, py)`` is a Gaussian Markov random field: along
each direction it is an AR(1) process with ``rho = exp(-pitch / l)``, whose precision ``Q1`` is
tridiagonal, and the field's precision is ``Q = Qx ⊗ Qy / sigma_a**2`` (nine entries a row).
The `n` points are `n` of the `N` nodes of the grid spanned by their bounding box (holes, masks
and repeated points allowed): ``A`` `n x N` selects them. With ``D = diag(noise)``::

    Σ = A Q⁻¹ Aᵀ + D,      M = Q + Aᵀ D⁻¹ A   (sparse, symmetric positive definite),
    log det Σ = Σ log d + log det M - log det Q,      rᵀ Σ⁻¹ r = rᵀ D⁻¹ r - bᵀ M⁻¹ b,   b = Aᵀ D⁻¹ r,

all exact (Woodbury). Readings without noise (``sigma_e = 0`` and ``sigma_m = 0``, or a zero
prediction with ``sigma_e = 0``) fix the field at their nodes `Z`; the density then integrates
the other nodes `R` only (:func:`_log_density_fixed`): ``M_RR`` with identity rows at `Z`, and
``b_R = c_R - Q_RZ r_Z``, ``c = Aᵀ D⁻¹ r`` over the noisy readings. ``log det Q`` is analytic
(``log det Q1 = -(m - 1) log(1 - rho**2)`` at unit variance). ``log det M`` and ``bᵀ M⁻¹ b`` come from one multifrontal elimination over the
grid's nested dissection with dense batched blocks (:mod:`torchshm.likelihood.lattice_frontal`),
once per distinct (``sigma_a``, ``l``, diagonal): load cases with the same diagonal share it.
Plain torch on the CPU, float64, differentiable by autograd. The quadratic form is a difference
of two terms that grow as ``sigma_a**2 / noise``: measured against the dense path, 7e-8 nat
apart at ``sigma_a / sigma_e = 1e3`` and 1e-5 nat at 1e4 (``docs/likelihood.md``). Draws: the
AR(1) recursion along each axis, O(N) (NumPy/SciPy, no gradients).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from scipy.signal import lfilter
from torch import Tensor

from torchshm.likelihood.constants import LOG_2PI
from torchshm.likelihood.lattice_frontal import _axis_entries, eliminate
from torchshm.likelihood.lattice_order import Grid, lattice
from torchshm.likelihood.lattice_plan import STENCIL

__all__ = ["Grid", "lattice", "log_density", "same_noise", "sample"]


def _factors(pitch: float, length: Tensor) -> tuple[Tensor, Tensor]:
    """``rho = exp(-pitch / l)`` and ``1 - rho**2`` (accurate near ``rho = 1``) of one direction."""
    step = pitch / length.clamp_min(1e-300)
    return (-step).exp(), -torch.expm1(-2.0 * step)


def log_density(resid: Tensor, noise: Tensor, x: Tensor, sigma_a: Tensor, length: Tensor) -> Tensor:
    """Log densities `B` of the residuals `B x L x n` [µε], summed over load cases.

    Load cases of a parameter vector with the same diagonal share one elimination. Computed on
    the CPU in float64 and differentiable (autograd) with respect to every input.

    Args:
        resid: ``y - eta`` `B x L x n` [µε]; noise: the diagonal `B x L x n` [µε²], >= 0 (a
            reading without noise is exact; two of them at one node are refused).
        x: `n x 2` coordinates [m] on one regular grid (:func:`lattice`).
        sigma_a: `B` scales [µε], > 0; length: `B` correlation lengths [m].

    Raises:
        ValueError: for points off a regular grid, a negative diagonal, or two readings without
            noise at one node (a singular density).
    """
    grid = lattice(x)
    if grid is None:
        raise ValueError("the lattice form needs n x 2 points on one regular grid (holes allowed)")
    if not bool((noise >= 0).all()):
        raise ValueError("the lattice form needs a diagonal of Eq. (21) >= 0")
    (nx, ny), (px, py) = grid.shape, grid.pitch
    cpu = dict(device="cpu", dtype=torch.float64)
    r, d, sa, ell = (t.to(**cpu) for t in (resid, noise, sigma_a, length))
    node = torch.from_numpy(grid.node)
    out = []
    for b in range(r.shape[0]):
        if bool(sa[b] == 0):  # no discrepancy: the diagonal alone
            out.append(-0.5 * (r[b].square() / d[b] + d[b].log() + LOG_2PI).sum())
            continue
        rx, sx = _factors(px, ell[b])
        ry, sy = _factors(py, ell[b])
        log_det_q = -ny * (nx - 1) * sx.log() - nx * (ny - 1) * sy.log() - 2.0 * nx * ny * sa[b].log()
        total = r.new_zeros(())
        for same in same_noise(d[b]):
            exact = d[b, same[0]] == 0
            if bool(exact.any()):  # readings without noise fix the field at their nodes
                total = total + _log_density_fixed(r[b, same], d[b, same[0]], node, (nx, ny),
                                                   (rx, sx, ry, sy), sa[b], log_det_q)
                continue
            inv = 1.0 / d[b, same[0]]
            weight = inv.new_zeros(nx * ny).index_add(0, node, inv)
            rhs = inv.new_zeros(nx * ny, len(same)).index_add(0, node, (inv * r[b, same]).T)
            log_det_m, bmb = eliminate((nx, ny), (rx, sx, ry, sy), sa[b].square().reciprocal(), weight, rhs)
            quad = (r[b, same].square() * inv).sum(-1) - bmb
            log_det = d[b, same[0]].log().sum() + log_det_m - log_det_q
            total = total - 0.5 * (quad.sum() + len(same) * (log_det + r.shape[2] * LOG_2PI))
        out.append(total)
    return torch.stack(out).to(device=resid.device, dtype=resid.dtype)


def _log_density_fixed(r: Tensor, d: Tensor, node: Tensor, shape: tuple[int, int],
                       factors: tuple[Tensor, Tensor, Tensor, Tensor], sigma_a: Tensor,
                       log_det_q: Tensor) -> Tensor:
    """Summed log density of the residuals `k x n` [µε] of load cases with one diagonal `n`
    [µε²] that is 0 at some readings (module docstring): those fix the field at their nodes `Z`,
    the others (`P`, noise ``d``) see it with their noise, and the nodes `R` (all but `Z`) are
    integrated out::

        log p = ½ bᵀ M_RR⁻¹ b - ½ log det M_RR + ½ log det Q - ½ (r_Zᵀ Q_ZZ r_Z + Σ_Z w r_Z²)
                + Σ_Z c r_Z - ½ r_Pᵀ D⁻¹ r_P - ½ Σ_P log d - ½ (n_P + |Z|) log 2π,

    ``M = Q + diag(w)``, ``w = Aᵀ D⁻¹ 1`` and ``c = Aᵀ D⁻¹ r`` over `P`, ``b = (c - Q r_Z)_R``.
    ``M_RR`` is eliminated as the nine-point matrix with identity rows and columns at `Z`
    (:func:`~torchshm.likelihood.lattice_frontal.eliminate`'s stencil).
    """
    nx, ny = shape
    exact = d == 0
    fixed_nodes = node[exact]
    if fixed_nodes.unique().numel() < fixed_nodes.numel():
        raise ValueError("the lattice form: two readings without noise (sigma_e = 0) at one grid node "
                         "make the density singular; give sigma_e > 0 or drop the repeated point")
    noisy = ~exact
    inv = torch.where(noisy, 1.0 / torch.where(noisy, d, 1.0), 0.0)  # 0 at the exact readings
    k = r.shape[0]
    weight = inv.new_zeros(nx * ny).index_add(0, node, inv)
    c = inv.new_zeros(nx * ny, k).index_add(0, node, (inv * r).T)  # N x k
    fixed = torch.zeros(nx * ny, dtype=torch.bool)
    fixed[fixed_nodes] = True
    rz = r.new_zeros(nx * ny, k).index_copy(0, fixed_nodes, r[:, exact].T)  # r_Z at Z, else 0
    scale = sigma_a.square().reciprocal()
    q_rz = _kron_apply(rz, shape, factors) * scale  # Q r_Z, N x k
    rhs = torch.where(fixed[:, None], 0.0, c - q_rz)
    stencil = _stencil(shape, factors, scale, weight, fixed)
    log_det_m, bmb = eliminate(shape, None, None, None, rhs, stencil=stencil)
    zz = (rz * q_rz).sum(0) + (weight[:, None] * rz.square()).sum(0) - 2.0 * (c * rz).sum(0)
    noisy_part = (r.square() * inv).sum(-1) + torch.where(noisy, d, 1.0).log().sum()
    count = int(noisy.sum()) + int(fixed_nodes.numel())
    return 0.5 * (bmb - zz - noisy_part).sum() + 0.5 * k * (log_det_q - log_det_m - count * LOG_2PI)


def _axis_apply(v: Tensor, axis: int, rho: Tensor, s: Tensor) -> Tensor:
    """``Q1 v`` along ``axis`` of ``v``: the tridiagonal unit-variance AR(1) precision."""
    size = v.shape[axis]
    if size == 1:
        return v
    lo, hi = v.narrow(axis, 0, size - 1), v.narrow(axis, 1, size - 1)
    zero = torch.zeros_like(v.narrow(axis, 0, 1))
    below = torch.cat([zero, lo], axis)  # v_(i-1)
    above = torch.cat([hi, zero], axis)  # v_(i+1)
    diag = torch.full((size,), 1.0, dtype=v.dtype) + rho * rho
    diag = torch.cat([diag.new_ones(1), diag[1:-1], diag.new_ones(1)])
    shape = [1] * v.ndim
    shape[axis] = size
    return (diag.reshape(shape) * v - rho * (below + above)) / s


def _kron_apply(v: Tensor, shape: tuple[int, int], factors: tuple[Tensor, Tensor, Tensor, Tensor]) -> Tensor:
    """``(Qx ⊗ Qy) v`` for `N x k` ``v`` (node ``i Ny + j``), unit variance."""
    (nx, ny), (rx, sx, ry, sy) = shape, factors
    grid = v.reshape(nx, ny, -1)
    return _axis_apply(_axis_apply(grid, 0, rx, sx), 1, ry, sy).reshape(nx * ny, -1)


def _stencil(shape: tuple[int, int], factors: tuple[Tensor, Tensor, Tensor, Tensor], scale: Tensor,
             weight: Tensor, fixed: Tensor) -> Tensor:
    """`N x 9` entries of ``Q scale + diag(weight)`` at the offsets of
    :data:`~torchshm.likelihood.lattice_plan.STENCIL`, with the rows and columns of the ``fixed``
    nodes `N` replaced by the identity's (entries pointing off the grid are 0, never read)."""
    (nx, ny), (rx, sx, ry, sy) = shape, factors
    node = torch.arange(nx * ny)
    i, j = node // ny, node % ny
    cols = []
    for di, dj in STENCIL:
        k, l = i + di, j + dj
        inside = (k >= 0) & (k < nx) & (l >= 0) & (l < ny)
        k, l = k.clamp(0, nx - 1), l.clamp(0, ny - 1)
        entry = _axis_entries(i, k, nx, rx, sx) * _axis_entries(j, l, ny, ry, sy) * scale
        if (di, dj) == (0, 0):
            entry = torch.where(fixed, 1.0, entry + weight)
        else:
            entry = torch.where(inside & ~fixed & ~fixed[k * ny + l], entry, 0.0)
        cols.append(entry)
    return torch.stack(cols, 1)


def same_noise(noise: Tensor) -> list[list[int]]:
    """Load cases (rows of `L x n` ``noise``) grouped by equal diagonals, in order."""
    groups: list[list[int]] = []
    for load in range(noise.shape[0]):
        for group in groups:
            if torch.equal(noise[group[0]], noise[load]):
                group.append(load)
                break
        else:
            groups.append([load])
    return groups


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
