"""How much memory a posterior predictive needs, known before anything is computed.

:func:`predictive_memory` counts the arrays of :func:`~torchshm.predictive.posterior_predictive`
for `n` draws of `L'` load cases at the `n_x` points of a problem's data view:

- the kept draws: `n x L' x n_x` float64 ``samples`` and ``eta`` (``keep="draws"``), or float32
  ``samples`` alone (``keep="summary"``, the command line's);
- the transients of one chunk of draws (:mod:`torchshm.predictive.chunks`,
  :data:`TRANSIENT_COPIES` float64 copies of it), and of the points summarised at once;
- a line drawn by the state space (1-D Markov kernels): its process noise for all draws at once
  (:data:`STATE_SPACE_COPIES` plus the kernel's state dimension, float64 copies of the line);
- the emulator's training outputs: at most
  :data:`~torchshm.predictive.predictive.MAX_TRAINING_POINTS` stored runs at the points
  (:data:`TRAINING_COPIES` float64 copies).

:func:`check_memory` refuses, in one line naming the fix, a predictive that would need more
than :data:`~torchshm.likelihood.marginal.DENSE_MEMORY_SHARE` of the physical memory, the share
the likelihood allows its dense covariances.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterable

import numpy as np

from torchshm.kernels import Kernel, get_kernel
from torchshm.likelihood.choice import DENSE_MEMORY_SHARE, _physical_memory
from torchshm.predictive.chunks import chunk_rows
from torchshm.predictive.draws import SUMMARY_CHUNK_BYTES
from torchshm.predictive.phases import line_method
from torchshm.predictive.view import PredictionView, prediction_view

if TYPE_CHECKING:
    from torchshm.problem import Problem

#: float64 copies of one chunk of draws alive at once (responses, variance, normals, products)
TRANSIENT_COPIES = 6
#: float64 copies of a state-space line's draws besides its state dimension
STATE_SPACE_COPIES = 2
#: float64 copies of the emulator's training outputs at the points
TRAINING_COPIES = 2
#: stored runs the emulator is trained on at most (``predictive.MAX_TRAINING_POINTS``)
TRAINING_RUNS = 400


def predictive_memory(problem_or_view: Problem | PredictionView, loads: Iterable[float] | float, n: int,
                      keep: str = "draws", kernel: str | Kernel | None = None) -> int:
    """Bytes a posterior predictive of ``n`` draws at ``loads`` needs (module docstring).

    Args:
        problem_or_view: the problem (its measured points and kernel) or a
            :class:`~torchshm.predictive.PredictionView` (then give ``kernel``).
        loads: the `L'` load cases to predict [m] (only their number counts).
        n: posterior draws.
        keep: ``"draws"`` or ``"summary"``, as :func:`~torchshm.predictive.posterior_predictive`.
        kernel: the discrepancy kernel (default: the problem's).

    Returns:
        The estimate [bytes]; ``tests/predictive/test_memory.py`` checks it against the arrays
        it counts, ``docs/benchmarks.md`` against the peak memory of a camera-sized field.
    """
    if isinstance(problem_or_view, PredictionView):
        if kernel is None:
            raise ValueError("predictive_memory: give the kernel with a PredictionView")
        view = problem_or_view
    else:
        view = prediction_view(problem_or_view)
        kernel = problem_or_view.kernel if kernel is None else kernel
    return memory_of_view(view, int(np.atleast_1d(np.asarray(loads, dtype=float)).size), n, keep, kernel)


def memory_of_view(view: PredictionView, n_loads: int, n: int, keep: str, kernel: str | Kernel) -> int:
    """:func:`predictive_memory` for ``n_loads`` load cases at the points of ``view``."""
    if keep not in ("draws", "summary"):
        raise ValueError(f"keep must be 'draws' or 'summary', got {keep!r}")
    kern = get_kernel(kernel)
    n_x = int(view.x.shape[0])
    values = n_loads * n_x  # numbers per draw
    kept = n * values * (16 if keep == "draws" else 4) + 3 * 8 * values
    chunk = TRANSIENT_COPIES * 8 * min(n, chunk_rows(values)) * values
    summary = 2 * min(8 * n * values, max(SUMMARY_CHUNK_BYTES, 8 * n))
    state = 0
    for part in view.parts:
        x = view.x[part.points]
        if x.ndim == 1 and line_method(kern, x, part.sigma_e, part.sigma_e > 0) == "state_space":
            copies = STATE_SPACE_COPIES + int(getattr(kern, "state_dim", 1))
            state = max(state, copies * 8 * n * n_loads * int(x.shape[0]))
    training = TRAINING_COPIES * 8 * TRAINING_RUNS * values
    return int(kept + chunk + summary + state + training)


def check_memory(view: PredictionView, n_loads: int, n: int, keep: str, kernel: str | Kernel,
                 what: tuple[str, str] = ("n", "loads")) -> None:
    """Refuse a predictive that needs more than ``DENSE_MEMORY_SHARE`` of the physical memory.

    Args:
        view, n_loads, n, keep, kernel: as :func:`memory_of_view`.
        what: the names of the draws' number and of the load cases in the message
            (``("predict.n", "predict.loads")`` on the command line, where the load cases are
            held out and ``keep`` is ``"summary"``).

    Raises:
        ValueError: one line with the size, the need, the machine's memory and the fix.
    """
    need, have = memory_of_view(view, n_loads, n, keep, kernel), _physical_memory()
    cap = DENSE_MEMORY_SHARE * have
    if need <= cap:
        return
    low, high = 0, n  # the most draws that fit (the need grows with n)
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (mid, high) if memory_of_view(view, n_loads, mid, keep, kernel) <= cap else (low, mid)
    cases = f"{n_loads} {'held-out ' if what[0] != 'n' else ''}load case{'s' if n_loads != 1 else ''}"
    fix = f"{what[0]}={low:,} or fewer" if low > 0 else "fewer points or"
    fix += f" {what[1]}"
    if keep == "draws":
        fix += ", or keep='summary' (float32 draws, no eta: a quarter of the memory)"
    raise ValueError(
        f"{what[0]}={n:,} draws of {n_points(view):,} points x {cases} need about {need / 2**30:.1f} GiB "
        f"for the posterior predictive, more than {DENSE_MEMORY_SHARE:.0%} of this machine's "
        f"{have / 2**30:.1f} GiB; use {fix}"
    )


def n_points(view: PredictionView) -> int:
    """Points of a prediction view."""
    return int(view.x.shape[0])
