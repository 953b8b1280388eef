"""Which form of the Eq. (21) Gaussian a kernel, a size and the points call for.

:func:`choose_method` is the one place that picks the form (``docs/likelihood.md``): the dense
Cholesky, the exact O(n) state space (Markov kernels along a line), the approximate full-scale
and Vecchia forms of fields, or a kernel's own exact sparse form (kernel ``upscaled``; kernel
``separable_exponential`` on a regular grid, ``"lattice"``), and refuses, with one line, a dense
covariance that would not fit in memory. :mod:`torchshm.likelihood.marginal` re-exports it.
"""

from __future__ import annotations

import logging
import os

import numpy as np
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.likelihood import fullscale, fullscale_choice, hilbert, statespace
from torchshm.likelihood.lattice_order import lattice

logger = logging.getLogger(__name__)

#: points per load case from which ``method="auto"`` uses the state-space form (measured)
STATE_SPACE_FROM = 1000
#: points per load case along a line from which ``method="auto"`` uses the reduced-rank form of
#: a kernel with a Gaussian spectral density (:mod:`torchshm.likelihood.hilbert`); rows whose
#: basis would exceed ``hilbert.SHARE`` of the points stay dense
HILBERT_FROM = 100
#: points per load case of a field (`n x d`, d >= 2) from which ``method="auto"`` uses the
#: full-scale (low rank + Vecchia) form: below it the exact dense path costs at most a few
#: seconds per evaluation
VECCHIA_FROM = 5000
#: the most neighbours and pivots of the full-scale form (chosen per call up to these,
#: :mod:`torchshm.likelihood.fullscale_choice`; ``docs/likelihood.md``), capped by memory
#: (:func:`torchshm.likelihood.fullscale.neighbours_for`, ``rank_for``)
FULLSCALE_NEIGHBOURS = fullscale_choice.NEIGHBOURS_MAX
FULLSCALE_RANK = fullscale_choice.RANK_MAX
#: share of the physical memory that dense covariances may take before they are refused
DENSE_MEMORY_SHARE = 0.5
#: what the full-scale form's warning adds for a kernel of the L1 distance (docs/likelihood.md)
L1_NOTE = ("for kernel 'separable_exponential' (L1 distance, off a regular grid, too many points for "
           "the dense form) larger: measured at 2,500 points, sigma_a = 5 µε, sigma_e = 0.05 µε, 0.03-0.07 "
           "nat at 1 pitch, 0.45-9.9 nat at 10-50 pitches (not measured at more points); points of one "
           "regular grid get the exact lattice form")
#: messages given once per process
_SAID = {"vecchia": False, "fullscale": False}
#: every method name a caller may ask for
METHODS = ("auto", "dense", "state_space", "diagonal", "vecchia", "fullscale", "lattice", "hilbert")


def choose_method(
    kern: Kernel, n: int, method: str = "auto", noise_positive: bool = True, dim: int = 1,
    x: Tensor | None = None,
) -> str:
    """``"diagonal"``, ``"dense"``, ``"state_space"``, ``"hilbert"``, ``"fullscale"``,
    ``"vecchia"``, ``"lattice"`` or a kernel's own form (``"upscaled"``) for `n` points per load
    case.

    ``"auto"`` takes the state space only when the diagonal of Eq. (21) is known to be
    positive (``noise_positive``, i.e. ``sigma_e > 0``), which the state-space form needs at
    repeated positions, and only for 1-D positions (``dim == 1``); `n x d` coordinates
    (``dim = d > 1``) are dense below :data:`VECCHIA_FROM` points and full-scale (low rank +
    Vecchia, :mod:`~torchshm.likelihood.fullscale`) from there; ``"vecchia"`` (plain nearest
    neighbours, fast and far less accurate) only when asked for. Kernel
    ``separable_exponential`` (L1 distance) takes ``"lattice"`` (exact, sparse) on `n x 2`
    points ``x`` of one regular grid (with ``noise_positive``, or without noise where no two points
    share a node: readings without noise are exact there); off a grid, as the other kernels of
    coordinates, with its L1 distances (neighbours and blocks of the Vecchia and full-scale
    forms taken in that distance). A kernel with a Gaussian
    spectral density (``squared_exponential``) along a line takes, from :data:`HILBERT_FROM`
    points with ``noise_positive``, the reduced-rank form (:mod:`~torchshm.likelihood.hilbert`:
    within 2e-5 nat of the dense form at up to 1,000 points; rows with short lengths stay dense).

    Raises:
        ValueError: for an unknown method, ``"state_space"`` with a kernel that has none,
            ``"vecchia"`` or ``"fullscale"`` for 1-D positions, ``"lattice"``
            or ``"hilbert"`` where it does not apply, or a dense covariance larger than
            :data:`DENSE_MEMORY_SHARE` of the physical memory.
    """
    own = getattr(kern, "form", None)  # a kernel with a sparse density of its own
    if own == "lattice":
        grid = _lattice_choice(kern, method, noise_positive, dim, x)
        if grid is not None:
            return grid
    elif own is not None and method in ("auto", own):
        if not noise_positive or dim != 2:
            raise ValueError(f"kernel {kern.name!r} needs n x 2 coordinates and sigma_e > 0")
        return own
    if method == "lattice":
        raise ValueError(f"method='lattice' is the sparse form of kernel 'separable_exponential' on a "
                         f"regular grid; kernel {kern.name!r} has none")
    if method not in METHODS:
        raise ValueError(f"method must be 'auto', 'dense', 'state_space', 'hilbert', 'fullscale', 'vecchia' "
                         f"or 'lattice', got {method!r}")
    if kern.is_diagonal:
        return "diagonal"
    if method == "diagonal":
        raise ValueError(f"kernel {kern.name!r} is not diagonal; use method='auto' or 'dense'")
    markov = statespace.is_markov(kern) and dim == 1
    if method == "state_space" and not markov:
        what = f"kernel {kern.name!r}" if dim == 1 else f"{dim}-D coordinates"
        raise ValueError(f"{what}: no state-space form; use method='dense'")
    if method == "state_space" or (method == "auto" and markov and noise_positive and n >= STATE_SPACE_FROM):
        return "state_space"
    if method in ("vecchia", "fullscale") and dim == 1:
        raise ValueError(f"method={method!r} is for n x d coordinates (d >= 2); positions along a "
                         "line use 'state_space' or 'dense'")
    if method == "vecchia":
        return method
    need, have = 2 * 8 * n * n, _physical_memory()
    fits = need <= DENSE_MEMORY_SHARE * have
    # the L1 kernel off a grid stays exact (dense) while that fits: its full-scale error is larger
    if method == "fullscale" or (method == "auto" and dim > 1 and n >= VECCHIA_FROM
                                 and (own != "lattice" or not fits)):
        _say_fullscale(n, dim, method, kern.l1)
        return "fullscale"
    if not fits:
        instead = (
            "use 'exponential', 'matern32' or 'matern52' with sigma_e > 0 (exact O(n) state space) "
            "or fewer points (a coarser pitch)" if dim == 1 else
            "points of one regular grid (holes allowed; sigma_e > 0 where points repeat) get the exact sparse form "
            "(method='lattice'); else method='fullscale' or fewer points (a coarser grid)" if own == "lattice" else
            f"{dim}-D coordinates: use method='fullscale' (low rank + nearest neighbours) or fewer "
            "points (a coarser grid)"
        )
        raise ValueError(
            f"{n} points per load case: a dense covariance needs {need / 2**30:.1f} GiB of "
            f"{have / 2**30:.1f} GiB for kernel {kern.name!r}; {instead}"
        )
    spectral = dim == 1 and hilbert.applies(kern)
    if method == "hilbert" and not (spectral and noise_positive):
        raise ValueError(f"method='hilbert' is for a kernel with a Gaussian spectral density along a line with "
                         f"sigma_e > 0; kernel {kern.name!r}, {dim}-D points: use 'dense'")
    if method == "hilbert" or (method == "auto" and spectral and noise_positive and n >= HILBERT_FROM):
        return "hilbert"  # rows it does not fit are dense (the memory check above holds for them)
    return "dense"


def _lattice_choice(kern: Kernel, method: str, noise_positive: bool, dim: int, x: Tensor | None) -> str | None:
    """``"lattice"`` where it applies to the L1 kernel ``kern``; None for the other paths.

    Raises:
        ValueError: for ``"lattice"`` where the points are not `n x 2` on one grid, or repeat a
            node with ``sigma_e`` 0.
    """
    if method not in ("auto", "lattice"):
        return None
    grid = lattice(x) if dim == 2 and x is not None else None
    # without noise, two readings at one node make the density singular (dense: a failed Cholesky);
    # the check only then (a sort of the nodes, per call)
    if grid is not None and (noise_positive or np.unique(grid.node).size == grid.node.size):
        return "lattice"
    if method == "lattice":
        raise ValueError(f"method='lattice' needs n x 2 points on one regular grid (holes allowed), and "
                         f"sigma_e > 0 where two points share a node; "
                         f"{'sigma_e is 0 and points repeat' if grid is not None else 'these points are not'}: use 'dense'")
    return None


def _say_fullscale(n: int, dim: int, method: str, l1: bool = False) -> None:
    """Say once per process that ``"auto"`` took the approximate full-scale form (and, for a
    kernel of the L1 distance, its larger error)."""
    if method == "auto" and not _SAID["fullscale"]:
        _SAID["fullscale"] = True
        rank = fullscale.rank_for(n, FULLSCALE_RANK)
        logger.warning(
            "%d points per load case of a %d-D field: the likelihood is the full-scale "
            "approximation (low rank of at most %d pivots + Vecchia with %d to %d neighbours, chosen "
            "per call from the kernel's length and the noise), not the exact density (its error: %s); "
            "%s; see docs/likelihood.md",
            n, dim, rank, fullscale.neighbours_for(n, fullscale_choice.NEIGHBOURS_RESOLVED),
            fullscale.neighbours_for(n, FULLSCALE_NEIGHBOURS), fullscale.error_note(n, rank),
            L1_NOTE if l1 else "the Euclidean kernels' figures",
        )


def _physical_memory() -> int:
    """Physical memory of this machine [bytes]."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 16 * 2**30
