"""Posterior predictive draws held in one array, computed in chunks of parameter vectors.

A predictive of `N` draws at `L'` load cases and `n_x` points needs, besides the draws it keeps,
transient arrays of the same size: the emulated responses and their variance, the emulator's
noise, the standard normals of Eq. (21). Made for all `N` vectors at once they are about nine
float64 copies of the draws (5.8 GiB for 500 draws of the camera example's 156,031 points, about
21 GiB for 2000); made for :func:`row_chunks` of about :data:`CHUNK_BYTES` per copy they cost a
few of those chunks (``docs/benchmarks.md``, "Posterior predictive of a camera's field").

The random numbers are the same as all at once: each stream is drawn in the order the
unchunked code draws it (all vectors' emulator noise, then per line all vectors' first term,
...), one chunk after the other. ``torch.randn`` fills a tensor in blocks of 16 numbers (its
last, partial block is drawn anew), so a chunk of `16 k` vectors continues the stream exactly
where the previous chunk stopped, and so does a last chunk of at least 16 vectors:
:func:`row_chunks` makes such chunks (``tests/predictive/test_chunks.py`` checks the numbers).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import torch
from torch import Tensor

#: bytes of one float64 copy of a chunk's draws (`rows x L' x n_x x 8`)
CHUNK_BYTES = 2**26
#: chunks are multiples of this many vectors (``torch.randn``'s block of 16 numbers)
ROW_BLOCK = 16

#: model responses `rows x L' x n_x` [µε] and their variance [µε²] (None: exact) at a chunk
Source = Callable[[slice], tuple[Tensor, "Tensor | None"]]


def chunk_rows(n_values: int, budget: int | None = None) -> int:
    """Vectors per chunk (a multiple of :data:`ROW_BLOCK`) for `n_values = L' x n_x` numbers
    each, so that one float64 copy of a chunk takes at most ``budget`` bytes (default
    :data:`CHUNK_BYTES`), at least 16 vectors."""
    budget = CHUNK_BYTES if budget is None else budget
    return max(ROW_BLOCK, budget // (8 * max(n_values, 1)) // ROW_BLOCK * ROW_BLOCK)


def row_chunks(n_rows: int, n_values: int, budget: int | None = None) -> list[slice]:
    """Consecutive chunks of `n_rows` vectors: :func:`chunk_rows` each, the last one longer
    (by fewer than 16) rather than shorter than 16, so that every stream continues exactly."""
    step = chunk_rows(n_values, budget)
    starts = list(range(0, n_rows, step))
    if len(starts) > 1 and n_rows - starts[-1] < ROW_BLOCK:
        starts.pop()
    return [slice(a, b) for a, b in zip(starts, [*starts[1:], n_rows])]


@dataclass
class DrawStore:
    """The arrays a predictive keeps.

    Attributes:
        out: `N x L' x n_x` responses, then draws [µε]: float64, or float32 for a result that
            is only summarised (its numbers then equal the float64 ones to float32 round-off).
        eta: `N x L' x n_x` float64 model responses [µε] (with the emulator's noise when it
            is used), or None when they are not kept.
    """

    out: Tensor
    eta: Tensor | None

    @classmethod
    def empty(cls, shape: tuple[int, int, int], keep: str) -> DrawStore:
        """Arrays of ``shape`` for ``keep="draws"`` (float64 draws and responses) or
        ``"summary"`` (float32 draws only)."""
        if keep not in ("draws", "summary"):
            raise ValueError(f"keep must be 'draws' or 'summary', got {keep!r}")
        if keep == "summary":
            return cls(torch.empty(shape, dtype=torch.float32), None)
        return cls(torch.empty(shape, dtype=torch.float64), torch.empty(shape, dtype=torch.float64))

    def put(self, rows: slice, eta: Tensor) -> None:
        """Responses ``eta`` of the vectors ``rows``."""
        self.out[rows] = eta
        if self.eta is not None:
            self.eta[rows] = eta


def fill_responses(store: DrawStore, chunks: list[slice], source: Source,
                   noise: torch.Generator | None = None) -> float:
    """Model responses of every chunk into ``store``; with ``noise``, plus the emulator's own
    uncertainty ``sd * z`` (:func:`add_emulator_noise`). Returns the largest emulator sd [µε]
    (0 without variance)."""
    largest = 0.0
    for rows in chunks:
        eta, var = source(rows)
        if var is not None:
            sd = var.clamp_min(0.0).sqrt()
            largest = max(largest, float(sd.max()))
            if noise is not None:
                eta = eta + sd * torch.randn(eta.shape, generator=noise, dtype=torch.float64)
        store.put(rows, eta)
    return largest


def add_emulator_noise(store: DrawStore, chunks: list[slice], source: Source,
                       noise: torch.Generator) -> None:
    """Add the emulator's noise ``sd * z`` to the stored responses, chunk by chunk (the
    variance is computed again; the responses too when ``store`` does not keep them)."""
    for rows in chunks:
        fresh, var = source(rows)
        eta = fresh if store.eta is None else store.eta[rows]
        sd = var.clamp_min(0.0).sqrt()
        store.put(rows, eta + sd * torch.randn(eta.shape, generator=noise, dtype=torch.float64))
