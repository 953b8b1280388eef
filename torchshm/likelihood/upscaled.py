"""The Gaussian of a strain field upscaled from independent element values (image correlation).

A finite-element image correlation (muDIC, and the Q4 solvers of other global DIC codes) gives
one strain per element of side ``length`` [m], at its centre, and often writes the field at many
more points than there are elements, bilinear between the centres (muDIC's
``Fields(upscale=3)``: nine points per element). With ``U`` `n x N` that interpolation (four
weights a row) and independent element values of sd ``sigma_a`` [µε]::

    y - eta ~ N(0, sigma_a**2 U Uᵀ + diag(noise))         (noise: sigma_e² + sigma_m² eta², `n`)

so the `n` points carry the information of the `N` elements behind them, however many points are
written. The density is computed through the elements (Woodbury): with ``Q = I / sigma_a**2`` on
the `N` element centres and ``M = Q + Uᵀ diag(noise)⁻¹ U``, ``log det`` = ``sum log noise + log
det M + N log sigma_a**2`` and the quadratic form is ``rᵀ noise⁻¹ r - bᵀ M⁻¹ b``, ``b = Uᵀ
noise⁻¹ r``. A point's four weights couple the four elements of its cell, so ``M`` has the
nine-point coupling of the lattice form (:mod:`torchshm.likelihood.lattice`) and is eliminated by
the same multifrontal pass over the element grid's nested dissection
(:func:`~torchshm.likelihood.lattice_frontal.eliminate`, its entries given as a stencil): plain
torch, float64, differentiable by autograd in the residuals, the diagonal, ``sigma_a`` and
``length``; about 0.2 s CPU for two load cases at 1.5e5 points, 1.3 s at 1.1e6
(``scripts/bench_likelihood_upscaled.py``). An element grid much finer than the points (more
than :data:`GRID_PER_POINT` elements a point) goes through a sparse LU (SciPy's SuperLU) of the
elements the points see, without gradients. Draws ``sigma_a U z`` are torch's sparse product.

The element grid is read from the points: its first centre is the smallest ``x`` and ``y`` of
the points (the first row and column of an upscaled field lie on element centres) and its pitch
is ``length``. The model's ``eta`` must be the strain the correlation would give (averaged over
each element, upscaled the same way): a residual outside the span of ``U`` is weighed by the
small ``noise`` alone. Independent elements are an approximation: neighbouring elements of a
global correlation share nodes, so their noise is correlated (``examples/plate_dic_camera``).
"""

from __future__ import annotations

import warnings

import numpy as np
import torch
from scipy import sparse
from scipy.sparse.linalg import splu
from torch import Tensor

from torchshm.kernels.upscaled import cells, operator
from torchshm.likelihood.constants import LOG_2PI
from torchshm.likelihood.lattice import same_noise
from torchshm.likelihood.lattice_frontal import eliminate


#: the whole element grid is eliminated (torch, differentiable) while it has at most this many
#: elements per point (points written every fourth element each way or closer); a finer one
#: (an element side far below the points' pitch, e.g. a ``length`` prior reaching towards 0)
#: goes through SciPy's sparse LU of the elements that the points see, without gradients
GRID_PER_POINT = 16


def log_density(resid: Tensor, noise: Tensor, x: Tensor, sigma_a: Tensor, length: Tensor) -> Tensor:
    """Log densities `B` of the residuals `B x L x n` [µε], summed over load cases.

    With ``Q = I / sigma_a**2`` on the `N` element centres of the points' grid,
    ``M = Q + Uᵀ D⁻¹ U`` has the nine-point coupling of neighbouring elements and is eliminated
    exactly by the lattice form's multifrontal pass (:func:`~torchshm.likelihood.lattice_frontal.eliminate`):
    ``log det Σ = Σ log d + log det M + N log sigma_a**2``, ``rᵀ Σ⁻¹ r = rᵀ D⁻¹ r - bᵀ M⁻¹ b``.
    Plain torch on the CPU in float64, differentiable (autograd) with respect to the residuals,
    the diagonal, ``sigma_a`` and ``length`` (through the bilinear weights). Load cases of a
    vector with the same diagonal share one elimination. An element grid of more than
    :data:`GRID_PER_POINT` elements per point takes the sparse LU instead (no gradients).

    Args:
        resid: ``y - eta`` `B x L x n` [µε]; noise: the diagonal `B x L x n` [µε²], > 0.
        x: `n x 2` coordinates [m]; sigma_a: `B` element sds [µε]; length: `B` element
            sides [m].
    """
    cpu = dict(device="cpu", dtype=torch.float64)
    r, d, sa, ell = (t.to(**cpu) for t in (resid, noise, sigma_a, length))
    xs = x.detach().to(**cpu)
    n = r.shape[2]
    grids: dict[float, tuple] = {}
    ops: dict[float, sparse.csr_matrix] = {}  # the sparse LU's operators, where it is taken
    out = []
    for b in range(r.shape[0]):
        if bool(sa[b] == 0):  # no element noise: the diagonal alone
            out.append(-0.5 * (r[b].square() / d[b] + d[b].log() + LOG_2PI).sum())
            continue
        if ell[b].requires_grad:
            grid = cells(xs, ell[b])
        else:
            grid = grids.get(float(ell[b])) or grids.setdefault(float(ell[b]), cells(xs, ell[b].detach()))
        (nx, ny), elements, weights = grid
        if nx * ny > GRID_PER_POINT * n:
            side = float(ell[b].detach())
            w = ops.get(side)
            if w is None:  # the operator once per element side, as the form before had it
                w = ops[side] = operator(xs.numpy(), side)
            value = _sparse_lu(r[b], d[b], w, float(sa[b].detach()))
            out.append(r.new_tensor(value))
            continue
        total = r.new_zeros(())
        for same in same_noise(d[b]):
            inv = 1.0 / d[b, same[0]]
            stencil = _element_matrix(elements, weights, inv, (nx, ny), sa[b])
            rhs = _element_rhs(elements, weights, (inv * r[b, same]).T, (nx, ny))
            log_det_m, bmb = eliminate((nx, ny), None, None, None, rhs, stencil=stencil)
            quad = (r[b, same].square() * inv).sum(-1) - bmb
            log_det = d[b, same[0]].log().sum() + log_det_m + nx * ny * sa[b].square().log()
            total = total - 0.5 * (quad.sum() + len(same) * (log_det + n * LOG_2PI))
        out.append(total)
    return torch.stack(out).to(device=resid.device, dtype=resid.dtype)


#: the corners of a cell ``(di, dj)`` in the order of :func:`~torchshm.kernels.upscaled.cells`
CORNERS = ((0, 0), (1, 0), (0, 1), (1, 1))


def _element_matrix(elements: Tensor, weights: Tensor, inv: Tensor, shape: tuple[int, int],
                    sigma_a: Tensor) -> Tensor:
    """`N x 9` entries of ``M = I / sigma_a**2 + Uᵀ diag(inv) U`` on the element grid, each row at
    the offsets of :data:`~torchshm.likelihood.lattice_plan.STENCIL` (bilinear weights couple the
    four elements of a cell: neighbours, diagonal ones included).

    The points' products ``w_a w_b / d`` are first summed per cell (one row of 16 per point),
    then each corner pair's cell sums are added to the grid's rows as one shifted slice."""
    nx, ny = shape
    pair = (weights[:, :, None] * weights[:, None, :] * inv[:, None, None]).reshape(-1, 16)
    diag = torch.zeros(9, dtype=inv.dtype)
    diag[4] = 1.0
    if nx < 2 or ny < 2:  # a line of elements: corners clipped onto each other, point by point
        ei, ej = elements // ny, elements % ny
        code = 3 * (ei[:, None, :] - ei[:, :, None] + 1) + (ej[:, None, :] - ej[:, :, None] + 1)
        flat = inv.new_zeros(nx * ny * 9).index_add(0, (elements[:, :, None] * 9 + code).reshape(-1), pair.reshape(-1))
        return flat.reshape(nx * ny, 9) + diag * sigma_a.square().reciprocal()
    sums = inv.new_zeros(nx * ny, 16).index_add(0, elements[:, 0], pair).reshape(nx, ny, 4, 4)[: nx - 1, : ny - 1]
    out = inv.new_zeros(nx, ny, 9)
    for a, (ai, aj) in enumerate(CORNERS):
        for b, (bi, bj) in enumerate(CORNERS):
            code = 3 * (bi - ai + 1) + (bj - aj + 1)
            out[ai:ai + nx - 1, aj:aj + ny - 1, code] += sums[:, :, a, b]
    return out.reshape(nx * ny, 9) + diag * sigma_a.square().reciprocal()


def _element_rhs(elements: Tensor, weights: Tensor, values: Tensor, shape: tuple[int, int]) -> Tensor:
    """``Uᵀ v`` `N x k` for point values ``values`` `n x k` (cell sums, then shifted slices, as
    :func:`_element_matrix`)."""
    nx, ny = shape
    k = values.shape[1]
    spread = weights[:, :, None] * values[:, None, :]  # n x 4 x k
    if nx < 2 or ny < 2:
        return values.new_zeros(nx * ny, k).index_add(0, elements.reshape(-1), spread.reshape(-1, k))
    sums = values.new_zeros(nx * ny, 4 * k).index_add(0, elements[:, 0], spread.reshape(-1, 4 * k))
    sums = sums.reshape(nx, ny, 4, k)[: nx - 1, : ny - 1]
    out = values.new_zeros(nx, ny, k)
    for a, (ai, aj) in enumerate(CORNERS):
        out[ai:ai + nx - 1, aj:aj + ny - 1] += sums[:, :, a]
    return out.reshape(nx * ny, k)


def _sparse_lu(resid: Tensor, noise: Tensor, w: sparse.csr_matrix, sigma_a: float) -> float:
    """The log density of one vector's residuals `L x n` through a sparse LU of ``I + sigma_a**2
    Uᵀ D⁻¹ U`` over the elements the points see (NumPy/SciPy, no gradients)."""
    r, d = resid.detach().numpy(), noise.detach().numpy()
    total = 0.0
    for load in range(r.shape[0]):
        if load == 0 or not np.array_equal(d[load], d[load - 1]):
            inv = 1.0 / d[load]
            lu = _factor(w, inv, sigma_a)
            log_det = np.log(d[load]).sum() + np.log(np.abs(lu.U.diagonal())).sum()
        z = inv * r[load]
        rhs = w.T @ z
        quad = r[load] @ z - sigma_a**2 * rhs @ lu.solve(rhs)
        total += -0.5 * (quad + log_det + r.shape[1] * LOG_2PI)
    return total


def sample(x: Tensor, sigma_a: Tensor, length: Tensor, n_loads: int, generator: torch.Generator,
           ops: dict[float, Tensor] | None = None) -> Tensor:
    """Draws `B x L x n` [µε] of ``sigma_a U z`` (``z``: standard normals of the elements that the
    points see, in ascending element number, from ``generator``, `L x N` per parameter vector in
    turn); ``ops``: ``U`` as a torch CSR tensor by element side, filled and reused (a caller
    drawing in chunks keeps them from chunk to chunk). Plain torch: differentiable in
    ``sigma_a`` and, where it requires a gradient, in ``length`` (then through the bilinear
    weights, by a gather about ten times slower than the sparse product at 10^6 points)."""
    xs, out = x.detach().to(device="cpu", dtype=torch.float64), []
    ops = {} if ops is None else ops
    for b in range(sigma_a.shape[0]):
        ell = length[b].to(device="cpu", dtype=torch.float64)
        if ell.requires_grad and torch.is_grad_enabled():
            columns, weights, n_seen = _seen(cells(xs, ell))
            z = torch.randn(n_loads, n_seen, generator=generator, dtype=torch.float64)
            field = (z.index_select(1, columns.reshape(-1)).view(n_loads, -1, 4) * weights).sum(-1)
        else:
            if float(ell) not in ops:
                columns, weights, n_seen = _seen(cells(xs, ell.detach()))
                rows = torch.arange(columns.shape[0]).repeat_interleave(4)
                with warnings.catch_warnings():  # "sparse CSR support is in beta": a product is all it does
                    warnings.simplefilter("ignore", UserWarning)
                    ops[float(ell)] = torch.sparse_coo_tensor(
                        torch.stack([rows, columns.reshape(-1)]), weights.reshape(-1),
                        (columns.shape[0], n_seen), check_invariants=False).coalesce().to_sparse_csr()
            u = ops[float(ell)]
            z = torch.randn(n_loads, u.shape[1], generator=generator, dtype=torch.float64)
            field = (u @ z.T).T  # L x n
        out.append(sigma_a[b].to(device="cpu", dtype=torch.float64) * field)
    return torch.stack(out).to(x.device)


def _seen(grid: tuple[tuple[int, int], Tensor, Tensor]) -> tuple[Tensor, Tensor, int]:
    """Each point's four corners as columns among the elements some point sees with a non-zero
    weight (ascending element number, as :func:`~torchshm.kernels.upscaled.operator` numbers
    them), their weights `n x 4`, and how many elements are seen."""
    _, elements, weights = grid
    seen = torch.unique(elements[weights != 0.0])
    columns = torch.searchsorted(seen, elements).clamp_max(seen.numel() - 1)
    return columns, weights, int(seen.numel())  # a zero weight's column: any one (it adds 0)


def _factor(w: sparse.csr_matrix, inv: np.ndarray, sigma_a: float):
    """Sparse LU of ``I + sigma_a**2 Uᵀ diag(inv) U`` (symmetric positive definite)."""
    m = sparse.identity(w.shape[1], format="csc") + sigma_a**2 * (w.T @ sparse.diags(inv) @ w).tocsc()
    return splu(m.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True})
