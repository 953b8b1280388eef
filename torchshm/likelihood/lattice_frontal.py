"""Multifrontal elimination of ``M = Q + diag(w)`` over a grid's nested dissection, in torch.

``Q = Qx ⊗ Qy / sigma_a**2`` (:mod:`torchshm.likelihood.lattice`), or any symmetric matrix
of the same nine-point coupling given by its entries (``stencil``: the upscaled field's element
matrix, :mod:`torchshm.likelihood.upscaled`). The fronts of
:func:`torchshm.likelihood.lattice_plan.plan` are eliminated group by group, children first,
each group in batched dense calls. A group's *joined sources* hold, per member, its children's
updates on their rings (written there by the children) and ``Q``'s entries of its eliminated
nodes; one gather (and a small add where two sources meet) assembles the front's rows ``[F_EE
F_EH]`` and its ring block ``F_HH``. Cholesky ``L`` of ``F_EE``, ``X = L⁻¹ F_EH``, and the update
``F_HH - Xᵀ X`` and right-hand side ``b_H - Xᵀ L⁻¹ b_E`` go to the parent. The sum of ``2 log
diag L`` is ``log det M`` and that of ``|L⁻¹ b_E|²`` is ``bᵀ M⁻¹ b``: one forward pass, no factor
kept. Plain torch, so autograd carries gradients through it.
"""

from __future__ import annotations

import torch
from torch import Tensor

from torchshm.likelihood.lattice_plan import plan

#: the most front entries assembled at once [float64 numbers] (a group is cut into chunks)
CHUNK_ENTRIES = 2**22


def _entries(u: Tensor, v: Tensor, shape: tuple[int, int], factors: tuple[Tensor, ...], scale: Tensor) -> Tensor:
    """``Q[u, v]`` for coupled nodes ``u``, ``v`` (any shape, node numbers ``i Ny + j``)."""
    (nx, ny), (rx, sx, ry, sy) = shape, factors
    return _axis_entries(u // ny, v // ny, nx, rx, sx) * _axis_entries(u % ny, v % ny, ny, ry, sy) * scale


def _stencil_entries(u: Tensor, v: Tensor, ny: int, stencil: Tensor) -> Tensor:
    """``M[u, v]`` for coupled nodes ``u``, ``v`` from the `N x 9` entries of each node's row at
    the offsets :data:`~torchshm.likelihood.lattice_plan.STENCIL` (``(di, dj)`` at ``3 (di + 1) +
    dj + 1``)."""
    code = 3 * (v // ny - u // ny + 1) + (v % ny - u % ny + 1)
    return stencil.reshape(-1)[u * 9 + code]


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
    places = torch.cat(targets).long()
    entry = torch.arange(places.numel())
    gather = torch.full((size,), places.numel(), dtype=torch.long).scatter_reduce_(0, places, entry, "amin")
    other = gather[places] != entry  # an entry of a later source at a place already taken
    return gather.to(torch.int32), places[other], entry[other]


def _layout(groups: list) -> tuple[list[list[tuple[int, int, int, int]]], list[list[int]]]:
    """Where each group's updates go: per group, ``(parent group, first member, members, column
    offset)`` ranges over its members (consecutive, in order); per group, the column offsets of
    its sources (children's updates, then ``Q``'s entries) in its joined buffer, and its width."""
    goes: list[list[tuple[int, int, int, int]]] = [[] for _ in groups]
    offsets: list[list[int]] = []
    for p, group in enumerate(groups):
        at, cols = [], 0
        for child, first, ring in group.children:
            goes[child].append((p, first, group.origin.shape[0], cols))
            at.append(cols)
            cols += ring.size * ring.size
        offsets.append(at + [cols, cols + group.pairs.shape[0] + int((group.pairs[:, 1] >= group.e).sum()) + 1])
    return [sorted(g, key=lambda r: r[1]) for g in goes], offsets


def _blocks(whole: tuple[Tensor, Tensor, Tensor], f: int, e: int) -> tuple[tuple, tuple]:
    """:func:`_assembly` of a front `f x f` cut into the rows of its `e` eliminated nodes
    (`e x f`) and its ring's block (`h x h`); the ring's rows' first `e` columns are not needed."""
    gather, places, entries = whole
    row, col = places // f, places % f
    hh = torch.arange(f * f).reshape(f, f)[e:, e:].reshape(-1)
    keep = (row >= e) & (col >= e)
    ring = (gather[hh], (row[keep] - e) * (f - e) + col[keep] - e, entries[keep])
    return (gather[: e * f], places[row < e], entries[row < e]), ring


def _gather(joined: Tensor, assembly: tuple[Tensor, Tensor, Tensor]) -> Tensor:
    """The sum of the sources in ``joined`` (`G x C x ...`: each source's entries, then a zero)
    placed by :func:`_assembly`."""
    gather, places, entries = assembly
    out = joined.index_select(1, gather)
    return out.index_add_(1, places, joined.index_select(1, entries)) if places.numel() else out


def eliminate(shape: tuple[int, int], factors: tuple[Tensor, Tensor, Tensor, Tensor] | None,
              scale: Tensor | None, weight: Tensor | None, rhs: Tensor,
              stencil: Tensor | None = None) -> tuple[Tensor, Tensor]:
    """``log det M`` and ``bᵀ M⁻¹ b`` for ``M = Qx ⊗ Qy * scale + diag(weight)``, or for the
    matrix of nine-point ``stencil`` entries.

    Args:
        shape: ``(Nx, Ny)`` grid nodes.
        factors: ``(rho_x, s_x, rho_y, s_y)`` (0-d tensors): AR(1) steps and ``1 - rho**2``.
        scale: ``1 / sigma_a**2`` (0-d tensor) [1/µε²].
        weight: `N` diagonal ``Aᵀ D⁻¹ 1`` [1/µε²]; rhs: `N x k` right-hand sides ``b = Aᵀ D⁻¹ r``
            [1/µε] (node ``i Ny + j``).
        stencil: instead of ``factors``, ``scale`` and ``weight`` (None there): `N x 9` entries
            of a symmetric positive definite ``M``, row ``i Ny + j`` at the columns of the
            offsets ``(di, dj)`` of :data:`~torchshm.likelihood.lattice_plan.STENCIL`, in its
            order (entries pointing off the grid are never read).

    Returns:
        ``log det M`` (0-d; +inf where a front is not positive definite in floating point) and
        the `k` values ``bᵀ M⁻¹ b``.

    One loop over the groups, children first, and over chunks of a group's members, in the
    order their parents read them: each chunk assembles its fronts from its joined sources,
    eliminates, and writes its updates into its parent group's joined sources (kept whole:
    the steps share many local tensors).
    """
    nx, ny = shape
    groups = plan(nx, ny)
    goes, offsets = _layout(groups)
    k = rhs.shape[1]
    joined: list[Tensor | None] = [None] * len(groups)  # per group: its children's updates and Q's entries
    joined_b: list[Tensor | None] = [None] * len(groups)
    like = weight if stencil is None else stencil
    log_det, quad = like.new_zeros(()), like.new_zeros(k)
    inputs = (rhs,) + ((*factors, scale, weight) if stencil is None else (stencil,))
    direct = not (torch.is_grad_enabled() and any(t.requires_grad for t in inputs))
    for g, group in enumerate(groups):
        f, e = group.f, group.e
        nodes = torch.from_numpy(group.nodes(ny))  # G x f
        a, b = torch.from_numpy(group.pairs[:, 0]), torch.from_numpy(group.pairs[:, 1])
        mirror = b >= e
        rings = [torch.from_numpy(at) for _, _, at in group.children]
        if group.assembly is None:  # the places of the front's sources, once per plan
            whole = _assembly(f * f, [(at[:, None] * f + at[None, :]).reshape(-1) for at in rings]
                              + [a * f + b, b[mirror] * f + a[mirror]])
            group.assembly = (*_blocks(whole, f, e), _assembly(f, rings + [torch.arange(e)]))
        into_rows, into_ring, into_vec = group.assembly
        own, width = offsets[g][-2], offsets[g][-1]
        own_b, width_b = sum(r.numel() for r in rings), sum(r.numel() for r in rings) + e + 1
        if joined[g] is None:  # a leaf: no child wrote here
            joined[g], joined_b[g] = _buffers(nodes.shape[0], width, width_b, k, like)
        step = max(1, CHUNK_ENTRIES // (f * f))
        for parent, first, count_p, col in goes[g] or [(-1, 0, nodes.shape[0], 0)]:
            for start in range(first, first + count_p, step):
                chunk = nodes[start:min(start + step, first + count_p)]
                count = chunk.shape[0]
                rows = slice(start, start + count)
                if stencil is None:
                    vals = (_entries(chunk[:, a], chunk[:, b], shape, factors, scale)
                            + torch.where(a == b, weight[chunk[:, a]], 0.0))
                else:
                    vals = _stencil_entries(chunk[:, a], chunk[:, b], ny, stencil)
                joined[g][rows, own:width - 1] = torch.cat([vals, vals[:, mirror]], 1)
                joined_b[g][rows, own_b:own_b + e] = rhs[chunk[:, :e]]
                top = _gather(joined[g][rows], into_rows).reshape(-1, e, f)  # the rows of E
                vec = _gather(joined_b[g][rows], into_vec)
                low, info = torch.linalg.cholesky_ex(top[:, :, :e])
                if bool((info != 0).any()):  # not positive definite in floating point
                    return like.new_tensor(torch.inf), quad
                c = torch.linalg.solve_triangular(low, vec[:, :e], upper=False)
                log_det = log_det + 2.0 * low.diagonal(dim1=-2, dim2=-1).log().sum()
                quad = quad + c.square().sum((0, 1))
                if parent < 0:
                    continue
                x = torch.linalg.solve_triangular(low, top[:, :, e:], upper=False)
                h = f - e
                ring = _gather(joined[g][rows], into_ring).reshape(-1, h, h)
                if joined[parent] is None:
                    joined[parent], joined_b[parent] = _buffers(
                        groups[parent].origin.shape[0], offsets[parent][-1], _width_b(groups[parent]), k, like)
                at_rows = slice(start - first, start - first + count)
                dest = joined[parent][at_rows, col:col + h * h].view(count, h, h)
                if direct:  # the update straight into the parent's sources
                    torch.baddbmm(ring, x.mT, x, alpha=-1.0, out=dest)
                else:  # autograd does not follow out=
                    dest.copy_(torch.baddbmm(ring, x.mT, x, alpha=-1.0))
                col_b = _column_b(groups[parent], col)
                joined_b[parent][at_rows, col_b:col_b + h] = vec[:, e:] - x.mT @ c
        joined[g] = joined_b[g] = None
    return log_det, quad


def _buffers(members: int, width: int, width_b: int, k: int, like: Tensor) -> tuple[Tensor, Tensor]:
    """A group's joined sources `G x width` and right-hand sides `G x width_b x k`, every column
    written by its children and itself but the last, a zero."""
    joined, joined_b = like.new_empty(members, width), like.new_empty(members, width_b, k)
    joined[:, -1] = 0.0
    joined_b[:, -1] = 0.0
    return joined, joined_b


def _width_b(group) -> int:
    """Width of a group's joined right-hand sides: its children's rings, its `e` nodes, a zero."""
    return sum(at.size for _, _, at in group.children) + group.e + 1


def _column_b(group, col: int) -> int:
    """Column of a child's right-hand sides in ``group``'s joined ones, from the column ``col``
    of its update."""
    cols, cols_b = 0, 0
    for _, _, at in group.children:
        if cols == col:
            return cols_b
        cols, cols_b = cols + at.size * at.size, cols_b + at.size
    raise ValueError(f"no child of the group writes at column {col}")
