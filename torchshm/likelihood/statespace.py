"""Exact O(n) Gaussian log densities and draws for Markov kernels on sorted 1-D positions.

The exponential, Matérn 3/2 and Matérn 5/2 discrepancies are the first component ``f`` of a
linear state ``s`` (dimension ``p`` = 1, 2, 3) that is Markov along the fibre::

    s_1 ~ N(0, sigma**2 P),   s_k = F_k s_{k-1} + q_k,   q_k ~ N(0, Q_k),
    Q_k = sigma**2 (P - F_k P F_kᵀ),   y_k = f_k + r_k,   r_k ~ N(0, D_k),

with ``F_k`` the closed-form transition over the step ``x_k - x_{k-1}`` (from the kernel's
``state_space``) and ``D_k > 0`` the diagonal of Eq. (21). The positions are cut into `G`
blocks of `size` (``docs/likelihood.md``):

1. in every block at once, a Kalman filter *from a known start state* ``s_0`` (the state at the
   position before the block) gives the block's innovation terms with ``s_0 = 0`` and how they
   move with ``s_0``: the filtered end state ``b + A s_0`` with covariance ``C``, and the
   block's likelihood ``exp(c + etaᵀ s_0 - s_0ᵀ J s_0 / 2)`` as a function of ``s_0``;
2. block after block, the filtered state before each block, ``s_0 ~ N(m, P)``, from these
   elements (the filtering elements of Särkkä and García-Fernández 2021, "Temporal
   parallelization of Bayesian smoothers", IEEE TAC 66(1));
3. all blocks at once, the Gaussian integral of each block's likelihood over ``s_0``.

Everything is exact (no approximation beyond floating point), covariance-form, so a zero step
(``F = I``, ``Q = 0``, repeated positions) and lengths far above the span (``Q`` tiny) are
exact and stable, and it is plain torch: differentiable by autograd, and runs on CUDA tensors.
The scalar state (exponential) has its own loop without small-matrix calls.

Draws of ``f`` are the same recursion with sampled ``q_k`` (:func:`sample`).
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.likelihood.constants import LOG_2PI

#: block size ``isqrt(n * BLOCK_FACTOR[p])`` for state dimension ``p`` (measured, docs/benchmarks.md)
BLOCK_FACTOR = {1: 0.6, 2: 1.2, 3: 1.2}
#: a batch of vectors (walkers, draws) gains from the state space from this many points per line
BATCH_STATE_SPACE_FROM = 64


def is_markov(kern: Kernel) -> bool:
    """Whether ``kern`` has a finite-dimensional state-space form (``state_space`` method)."""
    return getattr(kern, "state_dim", 0) > 0 and hasattr(kern, "state_space")


def _tables(x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """Transitions ``F`` and process covariances ``Q`` `B x (U + 2) x p x p` per kind of position
    and ``kind`` `n`, each position's: 0 the first (``F = 0``, ``Q = sigma_a**2 P``), ``1..U``
    the `U` distinct steps ``x_k - x_{k-1}``, ``U + 1`` padding (``F = Q = 0``)."""
    step = torch.diff(x, prepend=x[:1])
    values, index = torch.unique(step[1:], return_inverse=True)
    F, P = kern.state_space(values[None, :], length[:, None].clamp_min(0.0))  # B x U x p x p
    P = P * sigma_a.square()[:, None, None]  # B x p x p
    Q = P[:, None] - F @ P[:, None] @ F.mT
    zero = F.new_zeros(F.shape[0], 1, *F.shape[2:])  # (U may be 0: a single position)
    F = torch.cat([zero, F, zero], dim=1)
    Q = torch.cat([P[:, None], 0.5 * (Q + Q.mT), zero], dim=1)
    kind = torch.cat([index.new_zeros(1), index + 1])
    return F, Q, kind


def block_size(n: int, p: int) -> int:
    """Positions per block for `n` positions and state dimension `p`: about
    ``sqrt(n * BLOCK_FACTOR[p])``, within 5 % of it the size that pads least (no padding
    when a whole number of blocks fits, so the data need no padded copy)."""
    target = max(1, math.isqrt(int(n * BLOCK_FACTOR.get(p, 1.2))))
    sizes = range(max(1, (19 * target) // 20), min(n, (21 * target) // 20) + 1)
    return min(sizes, key=lambda size: (-n % size, abs(size - target)), default=target)


def _layout(t: Tensor, size: int, blocks: int, fill: float) -> Tensor:
    """`... x n` -> `size x ... x blocks` (position in block first; a strided view, of a padded
    copy when needed), padded with `fill` at the front of the first block to ``size * blocks``
    positions."""
    *lead, n = t.shape
    out = t
    if size * blocks > n:
        out = t.new_empty(*lead, size * blocks)
        out[..., : size * blocks - n] = fill
        out[..., size * blocks - n :] = t
    return out.unflatten(-1, (blocks, size)).movedim(-1, 0)


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
    F, Q, kind = _tables(x, kern, sigma_a, length)  # B x (U + 2) x p x p; the prior enters through Q_1
    p = F.shape[-1]
    size = block_size(n, p)
    blocks = -(-n // size)
    # padding: F = 0, Q = 0, y = 0, D = 1 — each padded position adds exactly -log(2 pi) / 2
    y, D = _layout(r, size, blocks, 0.0), _layout(noise, size, blocks, 1.0)  # size x B x L x G
    kinds = _layout(kind, size, blocks, F.shape[1] - 1).to(x.device)  # size x G
    if p == 1:
        F, Q = (t[:, kinds, 0, 0].movedim(1, 0)[:, :, None] for t in (F, Q))  # size x B x 1 x G
        elements, terms = _scalar_blocks(F, Q, y, D)
        total = terms + _scalar_merge(*elements)
    else:
        F, Q = (t.permute(2, 3, 0, 1)[..., kinds].movedim(3, 0)[..., None, :] for t in (F, Q))
        elements, terms = _matrix_blocks(F, Q, y, D)  # F, Q: size x p x p x B x 1 x G
        total = terms + _matrix_merge(*elements)
    return total.sum((-1, -2)) - 0.5 * L * n * LOG_2PI


def _scalar_blocks(a: Tensor, q: Tensor, y: Tensor, D: Tensor) -> tuple[tuple[Tensor, ...], Tensor]:
    """Known-start filter in every block at once, scalar state: elements ``(A, b, C, eta, J)``
    and ``-(sum v²/S + log S) / 2`` at ``s_0 = 0``, each `B x L x G`."""
    shape = y.shape[1:]
    m, P, g = y.new_zeros(shape), y.new_zeros(shape), y.new_ones(shape)
    eta, J, quad, logs = (y.new_zeros(shape) for _ in range(4))
    a2 = a.square()
    for j in range(y.shape[0]):
        Pp = torch.addcmul(q[j], a2[j], P)  # predicted variance
        S = Pp + D[j]
        w = S.reciprocal()
        mp, gp = a[j] * m, a[j] * g  # predicted mean and its derivative in s_0
        v = y[j] - mp
        vw = v * w
        quad = quad.addcmul(v, vw)
        logs = logs + S.log()
        eta = eta.addcmul(gp, vw)
        J = J.addcmul(gp * w, gp)
        c = D[j] * w  # 1 - gain
        m, g, P = torch.addcmul(mp, Pp, vw), gp * c, Pp * c
    return (g, m, P, eta, J), -0.5 * (quad + logs)


def _scalar_merge(A: Tensor, b: Tensor, C: Tensor, eta: Tensor, J: Tensor) -> Tensor:
    """Filtered ``N(m, P)`` before each block, block after block, then each block's Gaussian
    integral ``log E[exp(eta s_0 - J s_0² / 2)]`` over it; `B x L x G`."""
    A, b, C, eta, J = (t.movedim(-1, 0) for t in (A, b, C, eta, J))  # G x B x L
    m, P, one = torch.zeros_like(b[0]), torch.zeros_like(b[0]), torch.ones_like(b[0])
    ms, Ps = [m], [P]
    for Ag, A2g, bg, Cg, etag, Jg in zip(A[:-1], A[:-1].square(), b, C, eta, J):
        W = P / torch.addcmul(one, P, Jg)
        x = torch.addcmul(m, W, torch.addcmul(etag, Jg, m, value=-1.0))
        m, P = torch.addcmul(bg, Ag, x), torch.addcmul(Cg, A2g, W)
        ms.append(m)
        Ps.append(P)
    m, P = torch.stack(ms), torch.stack(Ps)
    den = 1.0 + P * J
    d = eta - J * m
    out = eta * m - 0.5 * J * m.square() + 0.5 * d.square() * P / den - 0.5 * den.log()
    return out.movedim(0, -1)


def _mm(X: Tensor, Y: Tensor) -> Tensor:
    """Products of stacks of small matrices stored component first: `p x q x ...` @ `q x r x ...`."""
    out = X[:, 0, None] * Y[None, 0]
    for k in range(1, X.shape[1]):
        out = out.addcmul(X[:, k, None], Y[None, k])
    return out


def _matrix_blocks(F: Tensor, Q: Tensor, y: Tensor, D: Tensor) -> tuple[tuple[Tensor, ...], Tensor]:
    """Known-start filter in every block at once, state dimension ``p > 1``: elements
    ``A, C, J`` `p x p x B x L x G`, ``b, eta`` `p x B x L x G`, and the terms at ``s_0 = 0``.
    The mean ``m`` and its derivative ``G`` in ``s_0`` share one stack ``M = [G | m]``, and the
    logs are taken after the loop: the number of small operations sets its time."""
    p, shape = F.shape[1], y.shape[1:]
    eye = torch.eye(p, dtype=y.dtype, device=y.device).reshape(p, p, *[1] * len(shape))
    M = torch.cat([eye.expand(p, p, *shape), y.new_zeros(p, 1, *shape)], dim=1)  # [G | m]
    P, J, eta = y.new_zeros(p, p, *shape), y.new_zeros(p, p, *shape), y.new_zeros(p, *shape)
    quad, S = y.new_zeros(shape), []
    FT = F.transpose(1, 2)
    for j in range(y.shape[0]):
        Fj = F[j]
        Pp = _mm(_mm(Fj, P), FT[j]).add_(Q[j])
        Pp = 0.5 * (Pp + Pp.transpose(0, 1))
        Mp = _mm(Fj, M)
        S.append(Pp[0, 0] + D[j])
        w = S[-1].reciprocal()
        v = y[j] - Mp[0, p]
        vw = v * w
        quad = quad.addcmul(v, vw)
        h = Mp[0, :p]  # derivative of the predicted observation in s_0, p x ...
        eta = eta.addcmul(h, vw)
        J = J.addcmul(h[:, None] * w, h[None])
        k = Pp[:, :1] * w  # gain, p x 1 x ...
        top = Mp[:1].clone()
        top[0, p] -= y[j]  # m = mp + k v = mp - k (mp_0 - y)
        M = Mp - k * top
        P = Pp - k * Pp[:1]
    return (M[:, :p], M[:, p], P, eta, J), -0.5 * (quad + torch.stack(S).log().sum(0))


def _matrix_merge(A: Tensor, b: Tensor, C: Tensor, eta: Tensor, J: Tensor) -> Tensor:
    """As :func:`_scalar_merge` for ``p > 1``: `B x L x G` block integrals."""
    A, C, J = (t.permute(4, 2, 3, 0, 1) for t in (A, C, J))  # G x B x L x p x p
    b, eta = (t.permute(3, 1, 2, 0)[..., None] for t in (b, eta))  # G x B x L x p x 1
    eye = torch.eye(A.shape[-1], dtype=A.dtype, device=A.device)
    m, P = torch.zeros_like(b[0]), torch.zeros_like(A[0])
    ms, Ps = [m], [P]
    for g in range(A.shape[0] - 1):
        W, _ = torch.linalg.solve_ex(eye + P @ J[g], P)
        m = A[g] @ (m + W @ (eta[g] - J[g] @ m)) + b[g]
        P = A[g] @ W @ A[g].mT + C[g]
        P = 0.5 * (P + P.mT)
        ms.append(m)
        Ps.append(P)
    m, P = torch.stack(ms), torch.stack(Ps)
    den = eye + P @ J
    W, _ = torch.linalg.solve_ex(den, P)
    d = eta - J @ m
    out = (eta * m).sum((-1, -2)) - 0.5 * (m * (J @ m)).sum((-1, -2))
    out = out + 0.5 * (d * (W @ d)).sum((-1, -2)) - 0.5 * torch.linalg.slogdet(den)[1]
    return out.movedim(0, -1)


def draw_block_size(n: int, columns: int) -> int:
    """Positions per block for draws at `n` positions with ``columns = B * L`` draws: enough
    blocks that each step works on about 2^16 numbers, at most ``sqrt(n)`` blocks."""
    blocks = min(max(1, -(-(2**16) // columns)), max(1, math.isqrt(n)))
    return -(-n // blocks)


def sample(
    x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, n_loads: int, generator: torch.Generator
) -> Tensor:
    """Draws of the discrepancy ``f`` `B x L x n` at sorted positions ``x``, O(n) time.

    ``s_1 = chol(sigma**2 P) z_1``, ``s_k = F_k s_{k-1} + Q_k^{1/2} z_k``, in blocks: every
    block at once runs the recursion from a zero start and keeps ``Phi_k``, the product of its
    transitions so far; the states before each block follow block after block; each position
    then adds ``(Phi_k s_0)_1``. ``F`` and the square root of ``Q`` (symmetric
    eigendecomposition, exact at a zero step) are computed once per distinct step length.
    ``z`` is drawn from ``generator`` step by step within the blocks, `p x B x L x blocks` at
    a time, on the CPU.

    Args:
        x: `n` sorted positions [m].
        kern: a kernel with ``state_space``.
        sigma_a: `B` scales [µε]; length: `B` correlation lengths [m].
        n_loads: `L`, independent draws per parameter vector.
        generator: source of the standard normals.
    """
    B, n, p, L = sigma_a.shape[0], x.shape[0], kern.state_dim, n_loads
    F, Q, kind = _tables(x, kern, sigma_a, length)  # B x (U + 2) x p x p, the kinds of position
    F, R = F.permute(2, 3, 0, 1), _root(Q).permute(2, 3, 0, 1)  # p x p x B x (U + 2)
    size = draw_block_size(n, B * L)
    blocks = -(-n // size)
    kinds = _layout(kind, size, blocks, F.shape[-1] - 1).to(x.device)  # size x blocks
    local = x.new_empty(size, L, B, blocks)  # columns L x B x G: F varies with the last two
    rows = x.new_empty(size, p, 1, B, blocks)
    state, new = x.new_zeros(p, L, B, blocks), x.new_empty(p, L, B, blocks)
    Phi = torch.eye(p, dtype=x.dtype, device=x.device)[..., None, None, None].repeat(1, 1, 1, B, blocks)
    z = torch.empty((p, L, B, blocks), dtype=x.dtype)
    for j, kj in enumerate(kinds):
        Fj, Rj = (t.index_select(3, kj)[:, :, None] for t in (F, R))  # p x p x 1 x B x G
        zj = z.normal_(generator=generator).to(x.device)
        for i in range(p):
            torch.mul(Fj[i, 0], state[0], out=new[i])
            for k in range(1, p):
                new[i].addcmul_(Fj[i, k], state[k])
            for k in range(p):
                new[i].addcmul_(Rj[i, k], zj[k])
        state, new = new, state
        Phi = _mm(Fj, Phi)
        local[j], rows[j] = state[0], Phi[0]
    start = x.new_zeros(p, L, B)
    starts = []
    for g in range(blocks):
        starts.append(start)
        start = _mm(Phi[..., g], start[:, None])[:, 0] + state[..., g]
    start = torch.stack(starts, dim=-1)  # p x L x B x G
    for k in range(p):
        local.addcmul_(rows[:, k], start[k])
    out = _transpose(local.reshape(size, -1)).reshape(L, B, blocks * size)
    return out.permute(1, 0, 2)[..., blocks * size - n :]  # a strided view, positions contiguous


def _transpose(t: Tensor, chunk: int = 2048) -> Tensor:
    """``t.T.contiguous()`` for a tall `a x b` matrix, a few columns at a time (cache-friendly)."""
    out = t.new_empty(t.shape[1], t.shape[0])
    for start in range(0, t.shape[1], chunk):
        out[start : start + chunk] = t[:, start : start + chunk].T
    return out


def _root(Q: Tensor) -> Tensor:
    """Square roots ``R`` with ``R Rᵀ = Q`` of positive semidefinite `... x p x p` matrices."""
    w, V = torch.linalg.eigh(Q)
    return V * w.clamp_min(0.0).sqrt()[..., None, :]
