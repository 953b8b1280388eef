"""Evaluate a forward model on a batch of parameter vectors, through an evaluation store.

The steps: canonicalise the batch; look every distinct θp up in the store; run the model for
the missing ones (and the failed ones when asked), each result stored as soon as it exists;
assemble the batch from stored and new results. A failing run never aborts the batch.
"""

from __future__ import annotations

import logging
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from torchshm.forward.cores import CoresPerRun, fit_workers
from torchshm.forward.protocol import model_identity, output_shape
from torchshm.storage import futures, runners
from torchshm.storage.interrupt import resumable
from torchshm.storage.keys import theta_key, canonical_theta
from torchshm.storage.record import Record
from torchshm.storage.store import EvaluationStore
from torchshm.storage.watchdog import Owner

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel

logger = logging.getLogger(__name__)


@dataclass
class EvaluationResult:
    """Outcome of :func:`evaluate` for a batch of `N` parameter vectors.

    Attributes:
        model: identity of the evaluated model.
        theta_p: canonical parameters `N x P` (12 significant digits).
        outputs: strains [µε] `N x L x n`; rows of failed evaluations are NaN.
        ok: `N` booleans, True where the evaluation succeeded.
        errors: `N` error texts (None where ok).
        n_new: model calls made by this call (store hits are not calls).
        n_reused: distinct parameter vectors found finished in the store.
        wall_time: `N` seconds each evaluation took when it ran (NaN if unknown).
    """

    model: str
    theta_p: np.ndarray
    outputs: np.ndarray
    ok: np.ndarray
    errors: list[str | None]
    n_new: int
    n_reused: int
    wall_time: np.ndarray = field(repr=False)

    @property
    def n_failed(self) -> int:
        """Number of rows whose evaluation failed."""
        return int((~self.ok).sum())

    def summary(self) -> str:
        """One paragraph: counts of rows, ok and failed, new and reused, and each failure."""
        n, n_distinct = len(self.ok), len({tuple(row) for row in self.theta_p.tolist()})
        text = (
            f"{n} evaluations of {self.model} ({n_distinct} distinct θp): "
            f"{n - self.n_failed} ok, {self.n_failed} failed; {self.n_new} new model runs, "
            f"{self.n_reused} reused from the store."
        )
        failed = [
            f"row {i} θp={self.theta_p[i].tolist()}: {_first_line(self.errors[i])}"
            for i in np.flatnonzero(~self.ok)
        ]
        return text + (" Failed: " + "; ".join(failed) + "." if failed else "")


def evaluate(
    model: ForwardModel,
    theta_p: object,
    store: EvaluationStore | str | Path | None = None,
    n_jobs: int = 1,
    executor: Any | None = None,
    retry_failed: bool = False,
    cores_per_run: int | None = None,
    cores_env: Sequence[str] = (),
) -> EvaluationResult:
    """Evaluate a forward model at every row of ``theta_p``, reusing stored evaluations.

    The model is called once per distinct θp, with a float64 tensor `P`, and must return
    strains `L_model x n_model` (or `1 x L_model x n_model`). A call that raises, or returns a
    wrong shape, NaN or inf, is recorded as failed with its error; the batch goes on.

    Args:
        model: a forward model (see :class:`torchshm.forward.ForwardModel`); it must be
            picklable when ``n_jobs != 1`` or ``executor`` is given. A
            :class:`~torchshm.storage.ParallelModel` is unwrapped: its model runs with its
            ``n_jobs``, ``executor`` and ``cores_per_run``.
        theta_p: parameters `N x P` or `P`, in the model's units.
        store: an :class:`EvaluationStore` or a path to one; None keeps nothing.
        n_jobs: local worker processes (joblib); -1 uses every core (with ``cores_per_run``:
            as many workers as fit). Ignored with ``executor``.
        executor: where the runs go, one task per θp: any object whose ``submit(fn, *args)``
            returns futures (a ``dask.distributed.Client``, see :func:`dask_client`; a
            ``concurrent.futures`` executor), this process storing each result when it is done;
            or a submitit executor (see :func:`make_executor`), one job of a job array per θp.
        retry_failed: run again the θp whose stored evaluation failed.
        cores_per_run: threads of one run (``OMP_NUM_THREADS`` and the others of
            :class:`~torchshm.forward.cores.CoresPerRun`); None leaves them as they are.
            Workers x ``cores_per_run`` must fit the machine (local workers only).
        cores_env: the program's own thread variables, set to ``cores_per_run`` too (e.g.
            ``["CCX_NPROC_EQUATION_SOLVER"]``).

    Returns:
        The :class:`EvaluationResult`, rows in the order of ``theta_p``.

    Raises:
        ValueError: if ``theta_p`` is not a finite `N x P` array, the model lacks ``x`` or
            ``loads``, ``n_jobs`` is 0, ``executor`` has no ``submit``, or the runs need more
            cores than the machine has.
        KeyboardInterrupt, SystemExit: on Ctrl-C or SIGTERM, after one line on stderr (see
            :func:`torchshm.storage.interrupt.resumable`); every finished run stays stored.
    """
    plan = getattr(model, "parallel_plan", None)  # a ParallelModel: its model and parallelism
    if plan is not None and n_jobs == 1 and executor is None:
        model, n_jobs, executor = plan
    theta = canonical_theta(theta_p)
    identity, shape = model_identity(model), output_shape(model)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, numbers.Integral) or n_jobs == 0:
        raise ValueError(f"n_jobs must be a non-zero integer, got {n_jobs!r}")
    n_jobs = int(n_jobs)
    if executor is not None:
        futures.check_executor(executor)
    if cores_per_run is not None:
        n_jobs = plan_cores(n_jobs, executor, cores_per_run)
        if not isinstance(model, CoresPerRun):
            model = CoresPerRun(model, cores_per_run, cores_env)
    if store is not None and not isinstance(store, EvaluationStore):
        store = EvaluationStore(store)
    keys = [theta_key(row) for row in theta]
    distinct = list(dict.fromkeys(keys))
    known: dict[str, Record] = {}
    if store is not None:
        store.ingest()
        known = store.lookup(identity, distinct)
    todo = [k for k in distinct if k not in known or (retry_failed and not known[k].ok)]
    logger.info("%s: %d distinct θp, %d in the store, %d to run", identity, len(distinct),
                len(distinct) - len(todo), len(todo))
    task = runners.Task(model, identity, shape, store, retry_failed, Owner.this_process())
    new: dict[str, Record] = {}
    n_calls = 0
    with resumable(f"evaluation of {identity}", None if store is None else store.path):
        if todo and executor is not None and callable(getattr(executor, "map_array", None)):
            new, n_calls = runners.run_submitit(task, todo, executor)
        elif todo and executor is not None:
            new, n_calls = futures.run_futures(task, todo, executor)
        elif todo and n_jobs != 1 and len(todo) > 1:
            new, n_calls = runners.run_joblib(task, todo, n_jobs)
        elif todo:
            new, n_calls = runners.run_serial(task, todo)
    if store is not None and new:
        store.ingest()  # results a worker could only deposit in the spool
    return _assemble(identity, theta, keys, {**known, **new}, shape, n_calls,
                     len(distinct) - n_calls)


def plan_cores(n_jobs: int, executor: Any | None, cores_per_run: int) -> int:
    """``n_jobs`` checked against the machine's cores for runs of ``cores_per_run`` threads.

    Local workers (joblib, or a Dask client's workers on this machine) x ``cores_per_run``
    must not exceed the cores; ``n_jobs=-1`` becomes as many workers as fit. Nothing is
    checked for a submitit executor or another executor (their resources are theirs).

    Raises:
        ValueError: naming the numbers, before any run.
    """
    if executor is None:
        return fit_workers(n_jobs, cores_per_run)
    if futures.is_dask_client(executor):
        from torchshm.storage.dask_cluster import check_client_cores

        check_client_cores(executor, cores_per_run)
    return n_jobs


def _assemble(
    identity: str, theta: np.ndarray, keys: list[str], records: dict[str, Record],
    shape: tuple[int, int], n_new: int, n_reused: int,
) -> EvaluationResult:
    outputs = np.full((len(keys), *shape), np.nan)
    ok = np.zeros(len(keys), dtype=bool)
    wall = np.full(len(keys), np.nan)
    errors: list[str | None] = []
    for i, key in enumerate(keys):
        record = records[key]
        ok[i], wall[i] = record.ok, record.wall_time
        if record.ok:
            outputs[i] = record.outputs
        errors.append(record.error)
    result = EvaluationResult(identity, theta, outputs, ok, errors, n_new, n_reused, wall)
    if result.n_failed:
        logger.warning("%s", result.summary())
    return result


def _first_line(text: str | None) -> str:
    lines = str(text).strip().splitlines()
    line = lines[0] if lines else ""
    return line if len(line) <= 300 else line[:297] + "..."
