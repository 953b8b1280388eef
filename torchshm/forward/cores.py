"""Cores of one model run: the thread variables a run sees, and runs that fit the machine.

A finite element program usually runs several threads (OpenMP, MKL, OpenBLAS, or its own
setting, e.g. CalculiX's ``CCX_NPROC_EQUATION_SOLVER``). With several runs at once, each must
use ``cores_per_run`` threads and ``workers x cores_per_run`` must not exceed the cores of the
machine, or the runs slow each other down. :class:`CoresPerRun` wraps a forward model so that
each call runs with those variables set (a program it starts inherits them) and with PyTorch's
and the BLAS libraries' threads limited (threadpoolctl) for a model computed in Python;
:func:`fit_workers` checks a number of workers before any run.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence
from typing import Any

import torch

#: variables set to ``cores_per_run`` for every run (OpenMP, Intel MKL, OpenBLAS)
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells, else all)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def check_cores_per_run(cores_per_run: object) -> int:
    """``cores_per_run`` as a positive int (``ValueError`` naming the value otherwise)."""
    if isinstance(cores_per_run, bool) or not isinstance(cores_per_run, int) or cores_per_run < 1:
        raise ValueError(f"cores_per_run must be a positive integer, got {cores_per_run!r}")
    return cores_per_run


def fit_workers(n_workers: int, cores_per_run: int, cores: int | None = None) -> int:
    """The number of workers, checked so that ``n_workers x cores_per_run <= cores``.

    Args:
        n_workers: worker processes; -1 asks for as many as fit (-2: one fewer, as joblib).
        cores_per_run: threads of one run.
        cores: cores of the machine; default :func:`available_cores`.

    Returns:
        ``n_workers``, or for a negative one ``cores // cores_per_run`` (at least 1) less
        ``-1 - n_workers``.

    Raises:
        ValueError: when the runs would need more cores than the machine has, or one run more
            than all of them; the message gives the numbers and what to change.
    """
    cores = available_cores() if cores is None else cores
    cores_per_run = check_cores_per_run(cores_per_run)
    if cores_per_run > cores:
        raise ValueError(f"cores_per_run={cores_per_run} is more than the {cores} cores of this machine")
    if n_workers < 0:
        return max(1, cores // cores_per_run + 1 + n_workers)
    if n_workers * cores_per_run > cores:
        raise ValueError(
            f"{n_workers} workers x cores_per_run={cores_per_run} need {n_workers * cores_per_run} "
            f"cores, but this machine has {cores}; lower n_jobs or cores_per_run "
            f"(n_jobs=-1 runs as many workers as fit: {max(1, cores // cores_per_run)})"
        )
    return n_workers


@contextlib.contextmanager
def thread_limits(cores_per_run: int, variables: Sequence[str] = ()) -> Iterator[None]:
    """Run the block with the thread variables (and ``variables``) set to ``cores_per_run``,
    PyTorch's threads and the BLAS pools limited to it; everything is restored afterwards."""
    from threadpoolctl import threadpool_limits

    names = list(dict.fromkeys([*THREAD_VARIABLES, *variables]))
    saved = {name: os.environ.get(name) for name in names}
    torch_threads = torch.get_num_threads()
    os.environ.update({name: str(cores_per_run) for name in names})
    torch.set_num_threads(cores_per_run)
    try:
        with threadpool_limits(limits=cores_per_run):
            yield
    finally:
        torch.set_num_threads(torch_threads)
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


class CoresPerRun:
    """A forward model whose every call runs with ``cores_per_run`` threads.

    Args:
        model: the forward model (picklable when it runs in workers).
        cores_per_run: threads of one run (``OMP_NUM_THREADS`` and the others of
            :data:`THREAD_VARIABLES`, PyTorch's and the BLAS libraries' threads).
        variables: the program's own variables set to the same number, e.g.
            ``["CCX_NPROC_EQUATION_SOLVER"]`` for CalculiX.

    Attributes:
        identity: ``model``'s identity (the store holds the same runs with and without it);
            every other attribute (``x``, ``loads``, ``names``, ...) is the model's.
    """

    def __init__(self, model: Any, cores_per_run: int, variables: Sequence[str] = ()) -> None:
        from torchshm.forward.protocol import model_identity

        self.model = model
        self.cores_per_run = check_cores_per_run(cores_per_run)
        self.variables = tuple(str(v) for v in variables)
        self.identity = model_identity(model)

    def __getattr__(self, name: str) -> Any:
        if name == "model":  # not set yet (unpickling)
            raise AttributeError(name)
        return getattr(self.model, name)

    def __call__(self, theta_p: object) -> Any:
        """The model's strains `... x L x n` [µε], computed under the thread limits."""
        with thread_limits(self.cores_per_run, self.variables):
            return self.model(theta_p)

    def __repr__(self) -> str:
        return f"CoresPerRun({self.model!r}, cores_per_run={self.cores_per_run})"


__all__ = ["THREAD_VARIABLES", "CoresPerRun", "available_cores", "check_cores_per_run",
           "fit_workers", "thread_limits"]
