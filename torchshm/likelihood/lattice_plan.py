"""The elimination plan of a grid's nested dissection, for a multifrontal factorisation.

The grid's `Nx x Ny` nodes are cut by geometric nested dissection (George 1973): a region is
split by the middle line across its longer side, regions of at most :data:`LEAF` nodes are not
split. Each region is one *front*: it eliminates its separator line (a
leaf: all its nodes) and passes to its parent a dense update on its *ring*, the nodes around the
region (the separators of its ancestors; with the 9-point coupling of ``Qx ⊗ Qy`` nothing else
touches it). Fronts of the same shape whose rings are clipped the same way by the grid's edges
have the same local structure up to a shift: they form one :class:`Group`, processed in one
batched call (:mod:`torchshm.likelihood.lattice_frontal`). Groups come children first.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: regions of at most this many nodes are not split (measured on 1000 x 1000, one thread, load ~5:
#: 4.5 s per elimination at 64, 4.7 s at 36, 4.85 s at 16; flat at 316 x 316)
LEAF = 64
#: the nine offsets of the coupling of ``Qx ⊗ Qy``
STENCIL = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)]


@dataclass
class Group:
    """Fronts of one local structure.

    Attributes:
        origin: `G x 2` grid indices of the fronts' first node.
        local: `f x 2` local coordinates of the front's nodes: the `e` eliminated ones first,
            then the ring.
        e: how many are eliminated.
        pairs: `P x 2` local indices ``(a, b)``, ``a < e``, of the coupled nodes whose entry of
            ``Q`` is added here.
        children: per child slot, ``(group index, place in that group of this group's first
            member's child (the others follow it), `h_c` local indices of the child's ring in
            this front)``.
    """

    origin: np.ndarray
    local: np.ndarray
    e: int
    pairs: np.ndarray
    children: list[tuple[int, int, np.ndarray]]
    #: where the front's entries come from (:func:`torchshm.likelihood.lattice_frontal.eliminate`
    #: fills it on its first pass over the plan)
    assembly: tuple | None = None

    @property
    def f(self) -> int:
        """Nodes of the front."""
        return int(self.local.shape[0])

    def nodes(self, ny: int) -> np.ndarray:
        """`G x f` grid node numbers ``i * Ny + j`` of the fronts."""
        coords = self.origin[:, None, :] + self.local[None, :, :]
        return coords[..., 0] * ny + coords[..., 1]


def _ring(h: int, w: int, sides: tuple[bool, bool, bool, bool]) -> list[tuple[int, int]]:
    """Local coordinates of the nodes around an `h x w` region (sides: above, below, left, right)."""
    up, down, left, right = sides
    j_lo, j_hi = (-1 if left else 0), (w if right else w - 1)
    out = [(-1, j) for j in range(j_lo, j_hi + 1)] if up else []
    out += [(h, j) for j in range(j_lo, j_hi + 1)] if down else []
    out += [(i, -1) for i in range(h)] if left else []
    out += [(i, w) for i in range(h)] if right else []
    return out


def _split(h: int, w: int) -> tuple[list[tuple[int, int]], list[tuple[int, int, int, int]]]:
    """Separator line (local coordinates) and the two halves ``(i0, j0, h, w)`` of a region."""
    if h >= w:
        m = h // 2
        return [(m, j) for j in range(w)], [(0, 0, m, w), (m + 1, 0, h - m - 1, w)]
    m = w // 2
    return [(i, m) for i in range(h)], [(0, 0, h, m), (0, m + 1, h, w - m - 1)]


@functools.lru_cache(maxsize=2)
def plan(nx: int, ny: int, leaf: int = LEAF) -> list[Group]:
    """The groups of fronts of an `nx x ny` grid, children first (cached for the last two
    shapes: with its assembly maps, about 0.2 GB at 10^6 nodes)."""
    keys: dict[tuple, int] = {}
    structure: list[tuple] = []  # per key: (local, e, pairs, child keys, region size)
    members: list[list[tuple[int, int]]] = []  # per key: origins
    parents: list[list[tuple[int, int]]] = []  # per key: (parent key, index in it) per member, per slot

    def key_of(h: int, w: int, i0: int, j0: int) -> tuple:
        return h, w, i0 > 0, i0 + h < nx, j0 > 0, j0 + w < ny

    todo = [(0, 0, nx, ny, -1, -1, 0)]
    while todo:
        i0, j0, h, w, parent, index, slot = todo.pop()
        key = key_of(h, w, i0, j0)
        if key not in keys:
            keys[key] = len(structure)
            ring = _ring(h, w, key[2:])
            if h * w <= leaf:
                elim, halves = [(i, j) for i in range(h) for j in range(w)], []
            else:
                elim, halves = _split(h, w)
            local = elim + ring
            where = {c: k for k, c in enumerate(local)}
            pairs = [(a, where[(u[0] + di, u[1] + dj)]) for a, u in enumerate(elim)
                     for di, dj in STENCIL if (u[0] + di, u[1] + dj) in where]
            kids = []
            for ci, cj, ch, cw in halves:
                child = key_of(ch, cw, i0 + ci, j0 + cj)
                at = [where[(ci + a, cj + b)] for a, b in _ring(ch, cw, child[2:])]
                kids.append((child, np.array(at, dtype=np.int64)))
            structure.append((np.array(local, dtype=np.int64), len(elim), np.array(pairs, dtype=np.int64), kids, h * w))
            members.append([])
            parents.append([])
        k = keys[key]
        members[k].append((i0, j0))
        parents[k].append((parent, index, slot))
        me = len(members[k]) - 1
        if h * w > leaf:
            _, halves = _split(h, w)
            for slot_c, (ci, cj, ch, cw) in enumerate(halves):
                todo.append((i0 + ci, j0 + cj, ch, cw, k, me, slot_c))
    return _groups(structure, members, parents, keys)


def _groups(structure: list[tuple], members: list[list[tuple[int, int]]],
            parents: list[list[tuple[int, int, int]]], keys: dict[tuple, int]) -> list[Group]:
    """Groups in children-first order (by area). Members are ordered parents first, each group's
    by (parent group, slot, parent's place), so that the children of one parent group and slot
    are consecutive in their group: a parent reads their updates as one slice."""
    order = sorted(range(len(structure)), key=lambda k: structure[k][4])  # a child's region is smaller
    rank = {k: r for r, k in enumerate(order)}
    place: dict[int, np.ndarray] = {}  # per key: each member's new place, by its old place
    for k in reversed(order):
        sort_key = [(-1, 0, 0) if p < 0 else (rank[p], slot, int(place[p][i])) for p, i, slot in parents[k]]
        perm = sorted(range(len(sort_key)), key=sort_key.__getitem__)
        place[k] = np.empty(len(perm), dtype=np.int64)
        place[k][perm] = np.arange(len(perm))
        members[k], parents[k] = [members[k][i] for i in perm], [parents[k][i] for i in perm]
    first: dict[tuple[int, int], int] = {}
    for k in range(len(structure)):
        for pos, (parent, index, slot) in enumerate(parents[k]):
            if parent >= 0:
                assert int(place[parent][index]) == pos - first.setdefault((parent, slot), pos)
    out = []
    for k in order:
        local, e, pairs, kids, _ = structure[k]
        children = [(rank[keys[child]], first[(k, s)], at) for s, (child, at) in enumerate(kids)]
        out.append(Group(np.array(members[k], dtype=np.int64).reshape(-1, 2), local, e, pairs, children))
    return out
