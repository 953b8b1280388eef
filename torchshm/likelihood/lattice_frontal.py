"""Multifrontal elimination of ``M = Q + diag(w)`` over a grid's nested dissection, in torch.

``Q = Qx ⊗ Qy / sigma_a**2`` (:mod:`torchshm.likelihood.lattice`). The fronts of
:func:`torchshm.likelihood.lattice_plan.plan` are eliminated group by group, children first,
each group in batched dense calls: assemble the front (``Q``'s entries of its eliminated nodes,
plus its children's updates), Cholesky of the eliminated block ``L``, ``X = L⁻¹ F_EH``, the
update ``F_HH - Xᵀ X`` and right-hand side ``b_H - Xᵀ L⁻¹ b_E`` passed to the parent. The sum of
``2 log diag L`` is ``log det M`` and the sum of ``|L⁻¹ b_E|²`` is ``bᵀ M⁻¹ b``: one forward
pass, no factor kept, memory of the order of the largest level's updates. Plain torch (dense
Cholesky, triangular solves, products), so autograd carries gradients through it.
"""

from __future__ import annotations

import torch
from torch import Tensor

from torchshm.likelihood.lattice_plan import plan

#: the most front entries assembled at once [float64 numbers] (a group is cut into chunks)
CHUNK_ENTRIES = 2**22


def _axis_entries(i: Tensor, k: Tensor, size: int, rho: Tensor, s: Tensor) -> Tensor:
    """Entries ``Q1[i, k]`` (``|i - k| <= 1``) of a unit-variance AR(1) precision of `size` nodes."""
    if size == 1:
        return torch.ones(i.shape, dtype=rho.dtype)
    end = (i == 0) | (i == size - 1)
    diag = torch.where(end, 1.0 / s, (1.0 + rho * rho) / s)
    return torch.where(i == k, diag, -rho / s)


def _assembly(size: int, targets: list[Tensor]) -> tuple[Tensor, Tensor, Tensor]:
    """How to sum sources into `size` places: ``targets`` are the (distinct) places of each
    source's entries, concatenated in that order and followed by one zero. Returns the gather
    that takes each place's entry from the first source that has it (or the zero), and the
    places and entries of the other sources' entries there (to add)."""
    total = sum(t.numel() for t in targets)
    gather = torch.full((size,), total, dtype=torch.int32)
    covered = torch.zeros(size, dtype=torch.bool)
    places, entries, offset = [], [], 0
    for t in targets:
        again = covered[t]
        places.append(t[again])
        entries.append(offset + torch.nonzero(again).reshape(-1))
        fresh = t[~again]
        gather[fresh] = (offset + torch.nonzero(~again).reshape(-1)).to(torch.int32)
        covered[fresh] = True
        offset += t.numel()
    return gather, torch.cat(places), torch.cat(entries)


def _gather(sources: list[Tensor], assembly: tuple[Tensor, Tensor, Tensor]) -> Tensor:
    """The sum of ``sources`` (`G x ...` each, joined along dimension 1) placed by
    :func:`_assembly`."""
    gather, places, entries = assembly
    joined = torch.cat(sources + [sources[-1].new_zeros(sources[-1].shape[0], 1, *sources[-1].shape[2:])], 1)
    out = joined.index_select(1, gather)
    return out.index_add_(1, places, joined.index_select(1, entries)) if places.numel() else out


def eliminate(shape: tuple[int, int], factors: tuple[Tensor, Tensor, Tensor, Tensor], scale: Tensor,
              weight: Tensor, rhs: Tensor) -> tuple[Tensor, Tensor]:
    """``log det M`` and ``bᵀ M⁻¹ b`` for ``M = Qx ⊗ Qy * scale + diag(weight)``.

    Args:
        shape: ``(Nx, Ny)`` grid nodes.
        factors: ``(rho_x, s_x, rho_y, s_y)`` (0-d tensors): AR(1) steps and ``1 - rho**2``.
        scale: ``1 / sigma_a**2`` (0-d tensor) [1/µε²].
        weight: `N` diagonal ``Aᵀ D⁻¹ 1`` [1/µε²]; rhs: `N x k` right-hand sides ``b = Aᵀ D⁻¹ r``
            [1/µε] (node ``i Ny + j``).

    Returns:
        ``log det M`` (0-d; +inf where a front is not positive definite in floating point) and
        the `k` values ``bᵀ M⁻¹ b``.
    """
    nx, ny = shape
    rx, sx, ry, sy = factors
    groups = plan(nx, ny)
    updates: list[tuple[Tensor, Tensor] | None] = [None] * len(groups)
    readers = [0] * len(groups)  # parent groups still to read a group's updates
    for group in groups:
        for child, _, _ in group.children:
            readers[child] += 1
    log_det, quad = weight.new_zeros(()), weight.new_zeros(rhs.shape[1:])
    for g, group in enumerate(groups):
        f, e = group.f, group.e
        nodes = torch.from_numpy(group.nodes(ny))  # G x f
        a, b = torch.from_numpy(group.pairs[:, 0]), torch.from_numpy(group.pairs[:, 1])
        mirror = b >= e
        kids = [(child, first, torch.from_numpy(at)) for child, first, at in group.children]
        if group.assembly is None:  # the places of the front's sources, once per plan
            group.assembly = (
                _assembly(f * f, [(at[:, None] * f + at[None, :]).reshape(-1) for _, _, at in kids]
                          + [a * f + b, b[mirror] * f + a[mirror]]),
                _assembly(f, [at for _, _, at in kids] + [torch.arange(e)]))
        into_front, into_vec = group.assembly
        step = max(1, CHUNK_ENTRIES // (f * f))
        parts_u, parts_b = [], []
        for start in range(0, nodes.shape[0], step):
            chunk = nodes[start:start + step]
            count = chunk.shape[0]
            u, v = chunk[:, a], chunk[:, b]  # G' x P
            iu, ju, iv, jv = u // ny, u % ny, v // ny, v % ny
            vals = _axis_entries(iu, iv, nx, rx, sx) * _axis_entries(ju, jv, ny, ry, sy) * scale
            vals = vals + torch.where(a == b, weight[u], 0.0)
            from_kids = [updates[child] for child, _, _ in kids]
            rows = [slice(first + start, first + start + count) for _, first, _ in kids]
            front = _gather([cu[r] for (cu, _), r in zip(from_kids, rows)] + [vals, vals[:, mirror]], into_front)
            vec = _gather([cb[r] for (_, cb), r in zip(from_kids, rows)] + [rhs[chunk[:, :e]]], into_vec)
            front = front.reshape(-1, f, f)
            low, info = torch.linalg.cholesky_ex(front[:, :e, :e])
            if bool((info != 0).any()):  # not positive definite in floating point
                return weight.new_tensor(torch.inf), quad
            c = torch.linalg.solve_triangular(low, vec[:, :e], upper=False)
            log_det = log_det + 2.0 * low.diagonal(dim1=-2, dim2=-1).log().sum()
            quad = quad + c.square().sum((0, 1))
            if f > e:
                x = torch.linalg.solve_triangular(low, front[:, :e, e:], upper=False)
                parts_u.append(torch.baddbmm(front[:, e:, e:], x.mT, x, alpha=-1.0).reshape(count, -1))
                parts_b.append(vec[:, e:] - x.mT @ c)
        if f > e:
            updates[g] = (parts_u[0], parts_b[0]) if len(parts_u) == 1 else (torch.cat(parts_u), torch.cat(parts_b))
        for child, _, _ in group.children:
            readers[child] -= 1
            if readers[child] == 0:
                updates[child] = None  # read by every parent group
    return log_det, quad
