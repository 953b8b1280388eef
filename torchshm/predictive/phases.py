"""The draws of Eq. (21), line by line, in chunks of parameter vectors, in place.

:func:`draw_lines` turns stored model responses into draws exactly as
:func:`~torchshm.predictive.draws.line_draws` does (one
:meth:`~torchshm.likelihood.marginal.Eq21.sample` per sensor line), with the same standard
normals from the same generator, but a chunk of vectors at a time
(:mod:`torchshm.predictive.chunks`): each of ``Eq21.sample``'s draws is a phase that runs over
every chunk before the next phase starts:

1. ``eta + sigma_m eta z1`` (`N x L x n` normals);
2. the discrepancy and noise: ``chol(K + sigma_e² I) z2`` (dense), ``sd z2`` (diagonal), the
   Vecchia factor's solve of ``z2`` (``"vecchia"``, ``"fullscale"``), or the element values
   ``sigma_a U z`` (``"upscaled"``, `L x N_el` normals per vector in turn) or the grid's AR(1)
   recursions (``"lattice"``, `L x Nx x Ny` normals per vector in turn), either followed by the
   noise ``sigma_e e``; the state space's process noise interleaves the vectors, so it is drawn
   for all of them at once (one `N x L x n` transient per line), then ``sigma_e e`` by chunks.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
from torch import Tensor

from torchshm.kernels import Kernel, get_kernel
from torchshm.likelihood import lattice, statespace, upscaled, vecchia
from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.marginal import SAMPLE_CHUNK_BYTES, choose_method, covariance
from torchshm.likelihood.statespace import is_markov
from torchshm.predictive.draws import STATE_SPACE_FROM

if TYPE_CHECKING:
    from torchshm.predictive.view import Part, PredictionView


def line_method(kern: Kernel, x: Tensor, sigma_e: float, noise_positive: bool) -> str:
    """The form of Eq. (21) the draws of one line take (as :func:`~torchshm.predictive.draws.line_draws`
    and :func:`~torchshm.predictive.draws.predictive_draws` choose it)."""
    markov = x.ndim == 1 and is_markov(kern) and sigma_e > 0
    form = "state_space" if markov and x.shape[0] >= STATE_SPACE_FROM else "auto"
    # the lattice draws (AR(1) recursions on the grid) need no noise, as in predictive_draws
    form = form if form != "auto" or noise_positive or getattr(kern, "form", None) == "lattice" else "dense"
    chosen = choose_method(kern, x.shape[0], form, dim=1 if x.ndim == 1 else int(x.shape[-1]), x=x)
    return "dense" if chosen == "hilbert" else chosen  # the reduced-rank form is the likelihood's


def draw_lines(out: Tensor, view: PredictionView, kernel: str | Kernel, sigma_a: Tensor,
               length: Tensor | None, sigma_m: float | Tensor, generator: torch.Generator,
               chunks: list[slice], sigma_e_scale: Tensor | None = None) -> None:
    """Replace the responses in ``out`` (`N x L' x n`, float64 or float32) by draws [µε].

    Args, as :func:`~torchshm.predictive.draws.line_draws`: the points and lines ``view``,
    the discrepancy ``kernel``, ``sigma_a`` and ``length`` `N x G`, ``sigma_m`` (a number or
    `N`), ``generator``, ``sigma_e_scale`` (`N` factors of an inferred σe, or None); and
    ``chunks``, the vectors' chunks (:func:`~torchshm.predictive.chunks.row_chunks`).
    """
    kern = get_kernel(kernel)
    whole = len(view.parts) == 1 and view.parts[0].points.numel() == out.shape[-1]
    for part in view.parts:
        points = slice(None) if whole else part.points
        sigma_e = part.sigma_e if sigma_e_scale is None else part.sigma_e * sigma_e_scale
        ell = length[:, part.group] if length is not None and kern.has_length else None
        _draw_line(out, points, view.x[points], kern, sigma_a[:, part.group], ell, sigma_m, sigma_e,
                   part, generator, chunks)


def _draw_line(out: Tensor, points: slice | Tensor, x: Tensor, kern: Kernel, sigma_a: Tensor,
               length: Tensor | None, sigma_m: float | Tensor, sigma_e: float | Tensor, part: Part,
               generator: torch.Generator, chunks: list[slice]) -> None:
    """The phases of ``Eq21.sample`` for one line (module docstring)."""
    ell = torch.zeros_like(sigma_a) if length is None else length
    positive = bool(torch.all(torch.as_tensor(sigma_e) > 0))
    method = line_method(kern, x, part.sigma_e, positive)

    def get(rows: slice) -> Tensor:
        return out[rows][..., points].to(torch.float64)

    def put(rows: slice, values: Tensor) -> None:
        block = out[rows]  # a view: writing into it writes into ``out``
        block[..., points] = values.to(out.dtype)

    def normals(rows: slice) -> Tensor:
        shape = (rows.stop - rows.start, out.shape[1], x.shape[0])
        return torch.randn(shape, generator=generator, dtype=torch.float64)

    for rows in chunks:  # phase 1: the multiplicative model error
        eta = get(rows)
        put(rows, eta + _rows(sigma_m, rows, eta) * eta * normals(rows))
    if method == "state_space":
        order = torch.argsort(x, stable=True)
        f = statespace.sample(x[order], kern, sigma_a, ell, out.shape[1], generator)
        ascending = bool((order[1:] > order[:-1]).all())
        for rows in chunks:
            values, e = get(rows), normals(rows)
            if ascending:
                values += f[rows] + _rows(sigma_e, rows, values) * e
            else:
                values[..., order] += f[rows] + (_rows(sigma_e, rows, values) * e)[..., order]
            put(rows, values)
        return
    if method in ("upscaled", "lattice"):  # element values or grid recursions, vector by vector
        ops: dict = {}  # the upscaled cells by element side, kept from chunk to chunk
        for rows in chunks:
            f = (upscaled.sample(x, sigma_a[rows], ell[rows], out.shape[1], generator, ops)
                 if method == "upscaled" else
                 lattice.sample(x, sigma_a[rows], ell[rows], out.shape[1], generator))
            put(rows, get(rows) + f.to(get(rows).device))
        for rows in chunks:
            values = get(rows)
            put(rows, values + _rows(sigma_e, rows, values) * normals(rows))
        return
    for rows in chunks:
        values = get(rows)
        put(rows, values + _second(method, x, kern, sigma_a[rows], ell[rows], sigma_e, rows, normals(rows)))


def _second(method: str, x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor,
            sigma_e: float | Tensor, rows: slice, z2: Tensor) -> Tensor:
    """The discrepancy and noise ``rows x L x n`` of the dense, diagonal and Vecchia forms from
    their normals ``z2`` (as ``Eq21.sample``)."""
    se = _rows(sigma_e, rows, z2)
    if method in ("vecchia", "fullscale"):
        if isinstance(sigma_e, Tensor) and sigma_e.ndim:
            return torch.cat([vecchia.sample(x, kern, sigma_a[i:i + 1], length[i:i + 1],
                                             float(se[i]) ** 2, z2[i:i + 1]) for i in range(z2.shape[0])])
        return vecchia.sample(x, kern, sigma_a, length, float(sigma_e) ** 2, z2)
    if method == "diagonal":
        points = x if x.ndim == 1 else x[:, 0]
        return (kern.diag(points, sigma_a=sigma_a)[:, None, :] + se.square()).sqrt() * z2
    n = x.shape[0]
    step = max(1, SAMPLE_CHUNK_BYTES // (n * n * 8))
    f = torch.empty_like(z2)
    for start in range(0, z2.shape[0], step):
        part = slice(start, start + step)
        noise = se[part].square().expand(-1, 1, n)
        chol, failed = cholesky_with_jitter(covariance(x, kern, sigma_a[part], length[part], noise))
        if bool(failed.any()):
            raise ValueError("predictive draws: a discrepancy covariance is not positive definite")
        f[part] = torch.matmul(chol[:, 0], z2[part].mT).mT
    return f


def _rows(value: float | Tensor, rows: slice, like: Tensor) -> Tensor:
    """A number, or the ``rows`` of an `N` tensor, as `rows x 1 x 1` (broadcasts with ``like``)."""
    if isinstance(value, Tensor) and value.ndim:
        return value[rows].to(like).reshape(-1, 1, 1)
    return torch.as_tensor(float(value), dtype=like.dtype).reshape(1, 1, 1).expand(like.shape[0], 1, 1)
