"""The Vecchia (nearest-neighbour) form of Eq. (21) for fields of `n x d` coordinates.

The density of one load case's residual ``r = y - eta`` (`n`) under the full covariance
``C = K + diag(D)``, ``D = sigma_m**2 eta**2 + sigma_e**2`` (Eq. 21), is written as a product of
conditionals in the order of a :class:`~torchshm.likelihood.neighbours.Plan`, each conditioned
on at most ``m`` nearest earlier points instead of all earlier points (Vecchia, 1988)::

    log p(r) ~ sum_i log N(r_i | C_iN C_NN^-1 r_N, C_ii - C_iN C_NN^-1 C_Ni),   N = N(i)

Each conditional is exact for its ``m + 1`` points, so any stationary kernel of the Euclidean
distance, irregular points, holes and the heteroscedastic diagonal enter without approximation;
only the conditioning sets are truncated. With ``L`` the Cholesky factor of the block
``C[N+i, N+i]`` (``i`` last) and ``z = L^-1 r[N+i]``, the conditional's terms are ``z_last²`` and
``log L_last,last²``. All blocks are built and factorised in batched torch calls, in chunks of
at most :data:`CHUNK_BYTES`: O(n m³) time, O(n m) memory, differentiable by autograd,
on CPU or CUDA tensors.

The same blocks give the sparse Cholesky factor of the approximate precision of
``K + sigma_e**2 I``: row ``i`` is ``(1, -b_i) / sqrt(v_i)``, ``b_i = C_NN^-1 C_Ni``; a draw is one
sparse triangular solve (:func:`sample`).
"""

from __future__ import annotations


import numpy as np
import scipy.sparse
import scipy.sparse.linalg
import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.likelihood import neighbours
from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.constants import LOG_2PI

#: largest batch of (m+1) x (m+1) blocks [bytes] built at once
CHUNK_BYTES = 2**24
#: neighbours per point by kernel (smoother kernels need more; ``docs/likelihood.md``)
NEIGHBOURS: dict[str, int] = {"exponential": 10, "matern32": 10, "matern52": 10, "squared_exponential": 10}
#: neighbours for a kernel not in :data:`NEIGHBOURS`
DEFAULT_NEIGHBOURS = 10


def neighbour_count(kern: Kernel) -> int:
    """``m`` for kernel ``kern`` (:data:`NEIGHBOURS`)."""
    return NEIGHBOURS.get(kern.name, DEFAULT_NEIGHBOURS)


def log_density(
    resid: Tensor, noise: Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, m: int | None = None
) -> Tensor:
    """Vecchia log densities `B` of residuals, summed over load cases.

    Args:
        resid: `B x L x n` residuals ``y - eta`` [µε].
        noise: `B x L x n` diagonal ``sigma_m**2 eta**2 + sigma_e**2`` [µε²].
        x: `n x d` coordinates [m].
        kern: the discrepancy kernel (a function of the Euclidean distance, or of the L1 one
            where ``kern.l1``: neighbours and block distances then are L1 ones).
        sigma_a: `B` scales [µε]; length: `B` correlation lengths [m].
        m: neighbours per point; ``None`` for :func:`neighbour_count`.

    Returns:
        `B` log densities; -inf where a block cannot be factorised even with jitter.
    """
    m = neighbour_count(kern) if m is None else m
    plan = neighbours.plan(x.detach().cpu().numpy(), m, kern.l1)
    order = torch.as_tensor(plan.order, device=x.device)
    resid, noise = resid[..., order], noise[..., order]
    n_vec, n_loads, n = resid.shape
    total = resid.new_zeros(n_vec)
    failed = torch.zeros(n_vec, dtype=torch.bool, device=x.device)
    step = _chunk(n_vec * n_loads, m)
    for start in range(0, n, step):
        chol, valid, safe, bad = _factor_blocks(plan, slice(start, start + step), kern, sigma_a, length, noise)
        r = torch.where(valid, resid[..., safe], 0.0)
        z = torch.linalg.solve_triangular(chol, r.unsqueeze(-1), upper=False)[..., -1, 0]
        terms = z.square() + 2.0 * chol[..., -1, -1].log() + LOG_2PI  # B x L x c
        total = total - 0.5 * terms.sum((-1, -2))
        failed |= bad
    return torch.where(failed, -torch.inf, total)


def sample(
    x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, noise: float, z: Tensor, m: int | None = None
) -> Tensor:
    """Draws `B x L x n` from the Vecchia approximation of ``N(0, K + noise I)``.

    The blocks of :func:`log_density` (with the diagonal ``noise``) give, per point in Vecchia
    order, ``b_i = C_NN^-1 C_Ni`` and ``v_i``; the draw solves the sparse unit lower-triangular
    system ``(I - B) f = v^(1/2) z`` (``scipy.sparse.linalg.spsolve_triangular``, on the CPU) for
    the `L` columns of each parameter vector. Not differentiable.

    Args:
        x: `n x d` coordinates [m].
        kern: the discrepancy kernel; sigma_a: `B` scales [µε]; length: `B` lengths [m].
        noise: the diagonal [µε²] (``sigma_e**2``), > 0 for a well-posed factor.
        z: `B x L x n` standard normals (in Vecchia order: rank ``i`` gets ``z[..., i]``).
        m: neighbours per point; ``None`` for :func:`neighbour_count`.

    Raises:
        ValueError: if a block is not positive definite even with jitter.
    """
    m = neighbour_count(kern) if m is None else m
    plan = neighbours.plan(x.detach().cpu().numpy(), m, kern.l1)
    n = x.shape[0]
    n_vec = sigma_a.shape[0]
    coef = np.zeros((n_vec, n, m + 1))  # -b_i, then sqrt(v_i)
    diag = torch.full((n_vec, 1, n), float(noise), dtype=x.dtype, device=x.device)
    step = _chunk(n_vec, m)
    with torch.no_grad():
        for start in range(0, n, step):
            chol, _, _, bad = _factor_blocks(plan, slice(start, start + step), kern, sigma_a, length, diag)
            if bool(bad.any()):
                raise ValueError("predictive draws: a discrepancy covariance is not positive definite")
            chol = chol[:, 0]
            lower = chol[..., -1, :-1].unsqueeze(-1)
            b = torch.linalg.solve_triangular(chol[..., :-1, :-1].mT, lower, upper=True)[..., 0]
            coef[:, start : start + step, :m] = -b.cpu().numpy()
            coef[:, start : start + step, m] = chol[..., -1, -1].cpu().numpy()
    rows = np.repeat(np.arange(n), m + 1)
    cols = plan.blocks.ravel()
    keep = cols >= 0
    out = torch.empty(z.shape, dtype=x.dtype)
    for k in range(n_vec):
        values = np.concatenate([coef[k, :, :m], np.ones((n, 1))], axis=1).ravel()
        factor = scipy.sparse.csr_matrix((values[keep], (rows[keep], cols[keep])), shape=(n, n))
        rhs = (z[k].cpu().numpy() * coef[k, :, m]).T  # n x L
        out[k] = torch.from_numpy(np.asarray(scipy.sparse.linalg.spsolve_triangular(factor, rhs, lower=True)).T)
    back = torch.empty_like(out)
    back[..., plan.order] = out
    return back.to(x.device)


def _chunk(matrices: int, m: int) -> int:
    """Points per chunk so that `matrices` blocks of `(m+1)^2` per point take CHUNK_BYTES."""
    return max(1, CHUNK_BYTES // (matrices * (m + 1) ** 2 * 8))


def _factor_blocks(
    plan: neighbours.Plan, part: slice, kern: Kernel, sigma_a: Tensor, length: Tensor, noise: Tensor,
    factor: Tensor | None = None,
) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """Cholesky factors of the blocks ``C[rows, rows]`` of the plan's rows ``part``.

    Without autograd only the lower triangles are filled (all that the factorisation reads); a
    missing slot is a decoupled unit variance.

    Args:
        plan: the Vecchia plan; part: its rows (`c` of them).
        sigma_a: `B` scales [µε]; length: `B` lengths [m]; noise: `B x L x n` ordered diagonal [µε²].
        factor: `B x c x M x r` rows of the low-rank factor ``F`` (Vecchia order) in the blocks of
            ``part`` (zero in missing slots), whose ``F Fᵀ`` is taken off the kernel (the
            residual covariance of :mod:`torchshm.likelihood.fullscale`), or None.

    Returns:
        ``(chol, valid, safe, failed)``: `B x L x c x M x M` factors, `c x M` true where a slot
        holds a point, `c x M` ranks (a missing slot points at the row's own point), `B` flags.
    """
    device = noise.device
    rows = torch.as_tensor(plan.blocks[part], device=device)
    valid = rows >= 0
    safe = torch.where(valid, rows, rows[:, -1:])
    size = rows.shape[1]
    low = torch.tril_indices(size, size, -1, device=device)
    dist = torch.as_tensor(plan.lower[part], device=device)  # c x T
    scale = sigma_a.square()[:, None, None]
    corr = scale * kern.correlation(dist, length[:, None, None])  # B x c x T
    var = scale[..., None]  # B x 1 x 1 (x c x M below)
    if factor is not None:  # residual of the low-rank part: K - F Fᵀ
        gram = factor @ factor.mT  # B x c x M x M
        corr = corr - gram[..., low[0], low[1]]
        var = var - gram.diagonal(dim1=-2, dim2=-1)[:, None]  # B x 1 x c x M
    if part.start < size:  # only the first m rows have missing slots
        corr = torch.where(valid[:, low[0]] & valid[:, low[1]], corr, 0.0)
    cov = noise.new_zeros(*noise.shape[:2], rows.shape[0], size, size)
    cov[..., low[0], low[1]] = corr[:, None]
    if corr.requires_grad:  # Cholesky's backward splits the gradient over both triangles
        cov[..., low[1], low[0]] = corr[:, None]
    diag = torch.where(valid, noise[..., safe] + var, 1.0)  # B x L x c x M
    cov = cov + torch.diag_embed(diag)
    chol, bad = cholesky_with_jitter(cov)
    return chol, valid, safe, bad.flatten(1).any(-1)
