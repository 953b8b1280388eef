"""Low rank plus Vecchia: the full-scale form of Eq. (21) for fields of `n x d` coordinates.

The Vecchia form (:mod:`torchshm.likelihood.vecchia`) alone loses tens to hundreds of nats
when the correlation length spans many pitches: each conditional sees the noise of `m`
neighbours, not of the whole field. Here the kernel is split (the full-scale approximation of
Sang and Huang, 2012, with a Vecchia residual as in GPBoost's Vecchia-inducing-points one)::

    K = F Fᵀ + (K - F Fᵀ),     F = K[:, P] R⁻ᵀ,   K[P, P] = R Rᵀ,

``P`` `r` pivots among the first points of the Vecchia plan's coarse-to-fine order (spread
over the field, chosen by a greedy pivoted Cholesky stopped by its residual; the rank and the
neighbours ``m`` are chosen per call, :mod:`torchshm.likelihood.fullscale_choice`),
``F Fᵀ`` the exact conditional-expectation (Nyström) part that carries the long range, and the
residual ``K - F Fᵀ`` (zero at the pivots, short-ranged) plus the diagonal ``D`` of Eq. (21)
approximated by Vecchia. With ``W = R_V⁻¹`` that Vecchia precision (``W = Uᵀ U`` row by row:
``u_i(v)`` is the last entry of ``L_i⁻¹ v[N(i)+i]``, ``L_i`` the Cholesky factor of point
``i``'s block; that last row of ``L_i⁻¹`` is ``[-wᵀ, 1] / d``, ``d`` the last diagonal entry of
``L_i`` and ``w`` one triangular solve with its last row), Woodbury gives the density of ``C = F Fᵀ + R_V`` exactly::

    log det C = log det R_V + log det(I + Fᵀ W F),
    rᵀ C⁻¹ r = rᵀ W r - gᵀ (I + Fᵀ W F)⁻¹ g,      g = Fᵀ W r.

``r = 0`` is the plain Vecchia form; as ``r`` grows the residual tends to ``D`` alone, which
Vecchia represents exactly, so the error falls with ``r`` (measured, ``docs/likelihood.md``).
Cost O(n (m³ + m² r + r²)) time, O(n r) memory; plain torch, differentiable, CPU or CUDA.
"""

from __future__ import annotations


import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.kernels.base import distances
from torchshm.likelihood import fullscale_choice, neighbours, vecchia
from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.constants import LOG_2PI

#: rows of the low-rank factor computed at once [bytes of `B x rows x r` float64]
CHUNK_BYTES = 2**24
#: largest stored block distances of the plan [bytes] (:func:`neighbours_for`)
PLAN_BYTES = 2**30
#: largest low-rank factor [bytes] per parameter vector (`n x r` float64)
FACTOR_BYTES = 2**28


def neighbours_for(n: int, requested: int) -> int:
    """The neighbours used for `n` points: ``requested``, at most what keeps the plan's stored
    block distances (`n x m(m+1)/2` float64) within :data:`PLAN_BYTES` (m = 15 at 10^6 points)."""
    m = requested
    while m > 10 and n * m * (m + 1) // 2 * 8 > PLAN_BYTES:
        m -= 1
    return m


def rank_for(n: int, requested: int) -> int:
    """The rank used for `n` points: ``requested``, at most what :data:`FACTOR_BYTES` holds."""
    return max(0, min(requested, n, FACTOR_BYTES // (8 * n)))


def low_rank(xo: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, pivots: Tensor) -> Tensor:
    """The factor `B x n x r` ``F = K[:, P] R⁻ᵀ`` of the pivots ``P`` (differentiable).

    Args:
        xo: `n x d` coordinates [m] in the plan's (coarse-to-fine) order.
        kern: the kernel; sigma_a: `B` scales [µε]; length: `B` lengths [m].
        pivots: `r` indices into ``xo`` (:func:`~torchshm.likelihood.fullscale_choice.choose`).
    """
    if pivots.numel() == 0:
        return xo.new_zeros(sigma_a.shape[0], xo.shape[0], 0)
    piv = xo[pivots]
    corr = kern.correlation(distances(piv, piv, l1=kern.l1), length[:, None, None])  # B x r x r
    chol, _ = cholesky_with_jitter(corr)
    step = max(1, CHUNK_BYTES // (8 * piv.shape[0] * sigma_a.shape[0]))
    parts = []
    for start in range(0, xo.shape[0], step):  # in chunks: the kernel's temporaries stay small
        cross = kern.correlation(distances(xo[start : start + step], piv, l1=kern.l1),
                                 length[:, None, None])  # B x c x r
        parts.append(torch.linalg.solve_triangular(chol, cross.mT, upper=False).mT)
    return sigma_a[:, None, None] * torch.cat(parts, dim=1)


def setting(x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, noise: Tensor,
            m: int | None = None, rank: int | None = None) -> tuple[neighbours.Plan, Tensor, fullscale_choice.Choice]:
    """The plan, the pivots and the choice of one call: ``m`` and ``rank`` as given, or, where
    None, chosen from the field (:func:`~torchshm.likelihood.fullscale_choice.choose`).

    Args:
        x: `n x d` coordinates [m]; noise: `B x L x n` diagonal [µε²] in ``x``'s order.
        kern: the kernel; sigma_a: `B` scales [µε]; length: `B` lengths [m].
        m: neighbours, or None; rank: the largest rank (capped by :func:`rank_for`), or None
            (:data:`~torchshm.likelihood.fullscale_choice.RANK_MAX`).
    """
    n = x.shape[0]
    points = x.detach().cpu().numpy()
    order = neighbours.plan(points, fullscale_choice.NEIGHBOURS_RESOLVED if m is None else m, kern.l1).order
    xo = x[torch.as_tensor(order, device=x.device)]
    cap = rank_for(n, fullscale_choice.RANK_MAX if rank is None else rank)
    if rank is not None and m is not None:  # as asked: the first pivots up to PIVOT_TOL
        with torch.no_grad():
            cand = xo[: fullscale_choice.CANDIDATES * cap]
            corr = kern.correlation(distances(cand, cand, l1=kern.l1), length.max().reshape(1, 1))
            pivots, _ = fullscale_choice.greedy_pivots(corr, cap)
        made = fullscale_choice.Choice(pivots, m, False, float("nan"))
    else:
        made = fullscale_choice.choose(xo, kern, sigma_a, length, noise, cap)
    used = neighbours_for(n, made.neighbours if m is None else m)
    return neighbours.plan(points, used, kern.l1), made.pivots, made


def log_density(
    resid: Tensor, noise: Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor,
    m: int | None = None, rank: int | None = None,
) -> Tensor:
    """Full-scale (low rank + Vecchia) log densities `B`, summed over load cases.

    Args:
        resid: `B x L x n` residuals ``y - eta`` [µε].
        noise: `B x L x n` diagonal ``sigma_m**2 eta**2 + sigma_e**2`` [µε²].
        x: `n x d` coordinates [m].
        kern: the discrepancy kernel; sigma_a: `B` scales [µε]; length: `B` lengths [m].
        m: Vecchia neighbours per point; rank: pivots of the low-rank part (capped by
            :func:`rank_for`; 0 is plain Vecchia). Both None (the default): chosen from the
            field per call (:mod:`~torchshm.likelihood.fullscale_choice`).

    Returns:
        `B` log densities; -inf where a block cannot be factorised even with jitter.
    """
    plan, pivots, _ = setting(x, kern, sigma_a, length, noise, m, rank)
    m = plan.neighbours
    order = torch.as_tensor(plan.order, device=x.device)
    resid, noise, xo = resid[..., order], noise[..., order], x[order]
    n_vec, n_loads, n = resid.shape
    factor = low_rank(xo, kern, sigma_a, length, pivots)
    r = factor.shape[-1]
    quad = resid.new_zeros(n_vec, n_loads)
    log_det = resid.new_zeros(n_vec, n_loads)
    gram = resid.new_zeros(n_vec, n_loads, r, r)
    proj = resid.new_zeros(n_vec, n_loads, r)
    failed = torch.zeros(n_vec, dtype=torch.bool, device=x.device)
    step = max(1, vecchia.CHUNK_BYTES // (n_vec * n_loads * (m + 1) * (m + 2 + r) * 8))
    padded = torch.cat([factor, factor.new_zeros(n_vec, 1, r)], 1)  # row n: a missing slot's zeros
    for start in range(0, n, step):
        part = slice(start, start + step)
        rows = torch.as_tensor(plan.blocks[part], device=x.device)
        rows_f = padded[:, torch.where(rows >= 0, rows, n)] if r else None  # B x c x M x r
        chol, valid, safe, bad = vecchia._factor_blocks(plan, part, kern, sigma_a, length, noise, rows_f)
        # the last row of each block's inverse factor, [-wᵀ, 1] / d, from one vector solve
        d = chol[..., -1, -1]  # B x L x c
        w = torch.linalg.solve_triangular(chol[..., :-1, :-1].mT, chol[..., -1, :-1].unsqueeze(-1), upper=True)
        w = w[..., 0]  # B x L x c x m
        rv = torch.where(valid, resid[..., safe], 0.0)  # B x L x c x M
        z = (rv[..., -1] - (w * rv[..., :-1]).sum(-1)) / d
        quad = quad + z.square().sum(-1)
        log_det = log_det + 2.0 * d.log().sum(-1)
        if r:
            rows_l = rows_f[:, None]  # B x 1 x c x M x r
            u = (rows_l[..., -1, :] - (w.unsqueeze(-2) @ rows_l[..., :-1, :])[..., 0, :]) / d[..., None]
            gram = gram + u.mT @ u
            proj = proj + (u.mT @ z.unsqueeze(-1))[..., 0]
        failed |= bad
    if r:
        inner = gram + torch.eye(r, dtype=gram.dtype, device=gram.device)
        chol_i = torch.linalg.cholesky(inner)
        log_det = log_det + 2.0 * chol_i.diagonal(dim1=-2, dim2=-1).log().sum(-1)
        v = torch.linalg.solve_triangular(chol_i, proj.unsqueeze(-1), upper=False)[..., 0]
        quad = quad - v.square().sum(-1)
    total = -0.5 * (quad + log_det + n * LOG_2PI).sum(-1)
    return torch.where(failed, -torch.inf, total)


def error_note(n: int, rank: int) -> str:
    """The measured error of the full-scale form whose rank is capped at ``rank``, for a warning."""
    note = ("measured at 10^4 points with sigma_a = 5 µε and sigma_e = 0.05 µε (the priors' hardest corner): "
            "within 0.05 nat where the pivots resolve the kernel to 1e-3 of the noise (squared exponential "
            "at l >= 0.2 x field, Matérn 5/2 at the field's size with sigma_m = 0.05); elsewhere, at the cap of "
            "512 pivots and 30 neighbours, 0.3-27 nat at lengths of 2-100 pitches and up to 1,510 nat "
            "(squared exponential, 2 pitches, sigma_m = 0)")
    if rank < fullscale_choice.RANK_MAX:
        note += (f"; at {n} points the rank is capped at {rank} by memory (FACTOR_BYTES), so where the pivots "
                 "do not resolve the kernel the error is larger by an unmeasured amount")
    return note
