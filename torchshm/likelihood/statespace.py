"""Exact O(n) Gaussian log densities and draws for Markov kernels on sorted 1-D positions.

The exponential, Matérn 3/2 and Matérn 5/2 discrepancies are the first component ``f`` of a
linear state ``s`` (dimension ``p`` = 1, 2, 3) that is Markov along the fibre::

    s_1 ~ N(0, sigma**2 P),   s_k = F_k s_{k-1} + q_k,   q_k ~ N(0, Q_k),
    Q_k = sigma**2 (P - F_k P F_kᵀ),   y_k = f_k + r_k,   r_k ~ N(0, D_k),

with ``F_k`` the closed-form transition over the step ``x_k - x_{k-1}`` (from the kernel's
``state_space``) and ``D_k > 0`` the diagonal of Eq. (21). The log density of ``y`` is the sum of
the Kalman filter's innovation terms (prediction error decomposition). The filter runs in
blocks of about ``sqrt(n / 4)`` positions: each block is reduced to one filtering element of the parallel-scan formulation of Särkkä and
García-Fernández (2021, "Temporal parallelization of Bayesian smoothers", IEEE TAC 66(1)), all
blocks at once; the elements are applied block after block; then an ordinary filter runs
inside all blocks at once (``docs/likelihood.md``). It is covariance-form, so a zero step
(``F = I``, ``Q = 0``, repeated positions) and lengths far above the span (``Q`` tiny) are
exact and stable, and it is plain torch: differentiable by autograd, and runs on CUDA tensors.

Draws of ``f`` are the same recursion with sampled ``q_k`` (:func:`sample`).
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from torchshm.kernels import Kernel

LOG_2PI = math.log(2.0 * math.pi)


def is_markov(kern: Kernel) -> bool:
    """Whether ``kern`` has a finite-dimensional state-space form (``state_space`` method)."""
    return getattr(kern, "state_dim", 0) > 0 and hasattr(kern, "state_space")


def _model(x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """Transitions `B x n x p x p` (the first is unused), process covariances `B x n x p x p`
    (the first is the stationary covariance) and stationary covariance `B x p x p`."""
    step = torch.diff(x, prepend=x[:1])  # n, step 0 at the first position
    F, P = kern.state_space(step[None, :], length[:, None].clamp_min(0.0))  # B x n x p x p
    scale = sigma_a.square()[:, None, None]
    P = P * scale  # B x p x p
    Q = P[:, None] - F @ P[:, None] @ F.mT
    Q = torch.cat([P[:, None].expand(-1, 1, -1, -1), Q[:, 1:]], dim=1)
    return F, 0.5 * (Q + Q.mT), P


def log_density(r: Tensor, noise: Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor) -> Tensor:
    """``log N(r; 0, K + diag(noise))`` for a Markov kernel, in O(n) time and memory.

    Args:
        r: `B x L x n` residuals ``y - eta`` [µε].
        noise: `B x L x n` diagonal ``sigma_m**2 eta**2 + sigma_e**2`` [µε²], > 0.
        x: `n` positions [m], sorted ascending (repeats allowed).
        kern: a kernel with ``state_space`` (see :func:`is_markov`).
        sigma_a: `B` discrepancy scales [µε].
        length: `B` correlation lengths [m].

    Returns:
        `B` log densities, each the sum over the `L` load cases (differentiable).
    """
    B, L, n = r.shape
    F, Q, _ = _model(x, kern, sigma_a, length)  # B x n x p x p
    F = torch.cat([torch.zeros_like(F[:, :1]), F[:, 1:]], dim=1)  # the prior enters through Q_1
    size = max(1, math.isqrt(n // 4))
    blocks = -(-n // size)
    steps = _blocked(F, Q, r, noise, size, blocks)  # F, Q: size x p x p x G x B x 1; y, D: size x G x B x L
    starts = _block_starts(_block_elements(*steps), blocks)
    return _filter(*steps, *starts).sum((0, 1, 3))


def _mm(X: Tensor, Y: Tensor) -> Tensor:
    """Products of stacks of small matrices stored component first: `p x q x M` @ `q x r x M`."""
    if X.shape[1] == 1:
        return X * Y
    return (X[:, :, None] * Y[None]).sum(1)


def _mv(X: Tensor, v: Tensor) -> Tensor:
    """`p x q x M` matrices times `q x M` vectors."""
    if X.shape[1] == 1:
        return X[:, 0] * v
    return (X * v[None]).sum(1)


def _blocked(F: Tensor, Q: Tensor, r: Tensor, noise: Tensor, size: int, blocks: int) -> tuple[Tensor, ...]:
    """Per-position model and data padded to ``blocks * size`` positions, laid out component
    first with ``M = blocks * B * L`` columns: `size x p x p x M` and `size x M`. Padded
    positions have ``F = I``, ``Q = 0`` and no observation (``seen = 0``)."""
    B, L, n = r.shape
    p, pad = F.shape[-1], blocks * size - n
    eye = torch.eye(p, dtype=F.dtype, device=F.device).expand(B, pad, p, p)
    F, Q = torch.cat([F, eye], dim=1), torch.cat([Q, torch.zeros_like(eye)], dim=1)

    def matrices(t: Tensor) -> Tensor:  # B x N x p x p -> size x p x p x G x B x 1
        return t.reshape(B, blocks, size, p, p).permute(2, 3, 4, 1, 0)[..., None].contiguous()

    def scalars(t: Tensor) -> Tensor:  # B x L x n -> size x G x B x L
        t = torch.cat([t, t.new_ones(*t.shape[:-1], pad)], dim=-1)
        return t.reshape(B, L, blocks, size).permute(3, 2, 0, 1).contiguous()

    seen = torch.cat([r.new_ones(n), r.new_zeros(pad)]).reshape(blocks, size).T[:, :, None, None]
    return matrices(F), matrices(Q), scalars(r) * seen, scalars(noise), seen


def _block_elements(F: Tensor, Q: Tensor, y: Tensor, D: Tensor, seen: Tensor) -> tuple[Tensor, ...]:
    """Filtering elements ``(A, b, C, eta, J)`` (`p x p x M`, `p x M`) of each block: the
    sequential combination of its positions' elements, all blocks at once. A position's element
    has a rank-one information part, so each step is a Sherman-Morrison update (no inverse)."""
    size, p, shape = F.shape[0], F.shape[1], y.shape[1:]  # shape: G x B x L
    A = torch.eye(p, dtype=F.dtype, device=F.device).reshape(p, p, 1, 1, 1).expand(p, p, *shape)
    b, h = y.new_zeros(p, *shape), y.new_zeros(p, *shape)
    C, J = y.new_zeros(p, p, *shape), y.new_zeros(p, p, *shape)
    for j in range(size):
        Fj, Qj, yj, S = F[j], Q[j], y[j], Q[j, 0, 0] + D[j]
        gain = Qj[:, 0] * (seen[j] / S)
        f = Fj[0] * seen[j]  # observation row through the transition
        A2 = Fj - gain[:, None] * Fj[None, 0]
        C2 = Qj - gain[:, None] * Qj[None, 0]
        u, g = _mv(C, f), _mv(A.transpose(0, 1), f)
        alpha = S + (f * u).sum(0)
        t = b + u * (yj / S)
        t = t - u * ((f * t).sum(0) / alpha)
        h = h + g * ((yj - (f * b).sum(0)) / alpha)
        J = J + g[:, None] * g[None] / alpha
        A = _mm(A2, A - u[:, None] * g[None] / alpha)
        C = _mm(_mm(A2, C - u[:, None] * u[None] / alpha), A2.transpose(0, 1)) + C2
        b = _mv(A2, t) + gain * yj
    return A, b, C, h, J


def _block_starts(elements: tuple[Tensor, ...], blocks: int) -> tuple[Tensor, Tensor]:
    """Filtered mean `p x M` and covariance `p x p x M` just before each block, by applying the
    block elements in turn (the first position's element ignores what it is given)."""
    A, b, C, h, J = elements  # p (x p) x G x B x L
    p, shape = b.shape[0], b.shape[1:]
    if p == 1:  # scalar state: the same recursion without small-matrix calls
        A, b, C, h, J = (e.expand(*e.shape[: e.ndim - 3], *shape).reshape(shape) for e in elements)
        ms, Ps = [torch.zeros_like(b[0])], [torch.zeros_like(b[0])]
        for g in range(blocks - 1):
            gain = A[g] / (1.0 + Ps[-1] * J[g])
            ms.append(gain * (ms[-1] + Ps[-1] * h[g]) + b[g])
            Ps.append(gain * A[g] * Ps[-1] + C[g])
        return torch.stack(ms)[None], torch.stack(Ps)[None, None]
    A, C, J = (e.expand(p, p, *shape).permute(2, 3, 4, 0, 1) for e in (A, C, J))
    b, h = b.permute(1, 2, 3, 0), h.permute(1, 2, 3, 0)  # G x B x L x p (x p)
    eye = torch.eye(p, dtype=b.dtype, device=b.device)
    means, covs = [torch.zeros_like(b[0])], [torch.zeros_like(A[0])]
    for g in range(blocks - 1):
        m, P = means[-1], covs[-1]
        inv, _ = torch.linalg.solve_ex(eye + P @ J[g], torch.cat([m[..., None] + P @ h[g][..., None], P], -1))
        means.append((A[g] @ inv[..., :1])[..., 0] + b[g])
        P = A[g] @ inv[..., 1:] @ A[g].mT + C[g]
        covs.append(0.5 * (P + P.mT))
    m, P = torch.stack(means), torch.stack(covs)  # G x B x L x p (x p)
    return m.permute(3, 0, 1, 2), P.permute(3, 4, 0, 1, 2)


def _filter(F: Tensor, Q: Tensor, y: Tensor, D: Tensor, seen: Tensor, m: Tensor, P: Tensor) -> Tensor:
    """Kalman filter inside every block at once, from the filtered state before each block;
    returns the innovation log densities `size x M` (0 at padded positions)."""
    terms = []
    for j in range(F.shape[0]):
        m = _mv(F[j], m)
        P = _mm(_mm(F[j], P), F[j].transpose(0, 1)) + Q[j]
        S = P[0, 0] + D[j]
        v = y[j] - m[0]
        terms.append(-0.5 * seen[j] * (v.square() / S + S.log() + LOG_2PI))
        gain = P[:, 0] * (seen[j] / S)
        m = m + gain * v
        P = P - gain[:, None] * P[None, 0]
        P = 0.5 * (P + P.transpose(0, 1))
    return torch.stack(terms)


def sample(
    x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, n_loads: int, generator: torch.Generator
) -> Tensor:
    """Draws of the discrepancy ``f`` `B x L x n` at sorted positions ``x``, O(n) time.

    ``s_1 = chol(sigma**2 P) z_1``, ``s_k = F_k s_{k-1} + Q_k^{1/2} z_k`` along the positions,
    all `B x L` draws at once. ``F`` and the square root of ``Q`` (symmetric eigendecomposition,
    exact at a zero step) are computed once per distinct step length, so a regular pitch costs a
    few small factorisations; ``z_k`` (`B x L x p`) are drawn from ``generator`` position by
    position, on the CPU.

    Args:
        x: `n` sorted positions [m].
        kern: a kernel with ``state_space``.
        sigma_a: `B` scales [µε]; length: `B` correlation lengths [m].
        n_loads: `L`, independent draws per parameter vector.
        generator: source of the standard normals.
    """
    B, n, p = sigma_a.shape[0], x.shape[0], kern.state_dim
    step = torch.diff(x, prepend=x[:1])
    values, index = torch.unique(step, return_inverse=True)
    F, P = kern.state_space(values[None, :], length[:, None].clamp_min(0.0))  # B x U x p x p
    P = P * sigma_a.square()[:, None, None, None]
    Q = P - F @ P @ F.mT
    roots = torch.cat([_root(P[:, :1]), _root(0.5 * (Q + Q.mT))], dim=1)  # B x (1 + U) x p x p
    out = x.new_empty(B, n_loads, n)
    state = x.new_zeros(B, n_loads, p)
    for k, u in enumerate(index.tolist()):
        z = torch.randn((B, n_loads, p), generator=generator, dtype=x.dtype).to(x.device)
        noise = (roots[:, u + 1 if k else 0, None] @ z[..., None])[..., 0]
        state = noise if k == 0 else (F[:, u, None] @ state[..., None])[..., 0] + noise
        out[..., k] = state[..., 0]
    return out


def _root(Q: Tensor) -> Tensor:
    """Square roots ``R`` with ``R Rᵀ = Q`` of positive semidefinite `... x p x p` matrices."""
    w, V = torch.linalg.eigh(Q)
    return V * w.clamp_min(0.0).sqrt()[..., None, :]
