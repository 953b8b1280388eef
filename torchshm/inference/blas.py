"""NumPy's and SciPy's BLAS threads: one during a method's own work, the user's during model runs.

A method's own NumPy and SciPy work is on small matrices (PyVBMC's GP and variational
updates, emcee's moves, L-BFGS-B's steps, the emulator's bookkeeping) and sits between calls
of torch, which has threads of its own. There, OpenBLAS's threads only spin: with two threads
each on two cores the VBMC main job took 141 s wall (176 s CPU) against 75 s with OpenBLAS on
one thread (docs/benchmarks.md, "The main job"). A model computed in Python in the same
process may want its BLAS threads, so a model run gets back the number the process had.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from threadpoolctl import ThreadpoolController

_controller: ThreadpoolController | None = None
#: BLAS threads of the process outside :func:`own_work` (None: not inside it)
_outside: int | None = None


def _get() -> ThreadpoolController:
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller


@contextlib.contextmanager
def own_work() -> Iterator[None]:
    """Run a method's own work with NumPy's and SciPy's BLAS on one thread (restored after)."""
    global _outside
    controller = _get()
    blas = controller.select(user_api="blas")
    saved = _outside
    if saved is None:
        _outside = max((lib.num_threads for lib in blas.lib_controllers), default=1)
    try:
        with controller.limit(limits=1, user_api="blas"):
            yield
    finally:
        _outside = saved


@contextlib.contextmanager
def model_work() -> Iterator[None]:
    """Within :func:`own_work`, run a model with the BLAS threads the process had outside it."""
    if _outside is None or _outside <= 1:
        yield
        return
    with _get().limit(limits=_outside, user_api="blas"):
        yield
