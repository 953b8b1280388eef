"""Running the missing evaluations of a batch: in process, with joblib, or with submitit
(any other executor with ``submit``: :mod:`torchshm.storage.futures`).

Each runner calls the model once per parameter vector and hands every result to the store as
soon as it exists, from the process that ran it: in process and with joblib the worker
commits to the SQLite file itself; a submitit job (possibly on another machine) deposits its
result in the store's spool folder. Scheduling is left to joblib and submitit.

In process and with joblib, the store is asked again just before each model call and the θp
is claimed (:mod:`torchshm.storage.claims`), so a run that another process finished meanwhile
or is running now (several studies sharing a store) is not repeated.
"""

from __future__ import annotations

import functools
import logging
import os
import socket
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import joblib
import submitit
from joblib.externals.loky.process_executor import TerminatedWorkerError

from torchshm.storage import claims
from torchshm.storage.keys import key_theta
from torchshm.storage.record import Record, now_utc, run_model
from torchshm.storage.store import EvaluationStore
from torchshm.storage.watchdog import Owner, watch_owner

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Task:
    """What every evaluation of one batch shares (picklable, sent to workers).

    Attributes:
        model: the forward model.
        identity: its identity in the store.
        shape: expected output shape `(L_model, n_model)`.
        store: where results go, or None.
        retry_failed: whether a stored failure is run again.
        owner: the process that asked for the runs; a worker on its host ends when it dies
            (:mod:`torchshm.storage.watchdog`).
        spool: the store's spool folder, for a worker that has no store but may reach the
            folder (:func:`torchshm.storage.futures.run_remote`); None otherwise.
    """

    model: ForwardModel
    identity: str
    shape: tuple[int, int]
    store: EvaluationStore | None
    retry_failed: bool = False
    owner: Owner | None = None
    spool: Path | None = None


#: a runner's result: key -> record, and the number of model calls made
Outcome = tuple[dict[str, Record], int]


def run_serial(task: Task, keys: Sequence[str]) -> Outcome:
    """Evaluate one key after the other in this process, committing each result at once."""
    results = [_run_and_save(task, key) for key in keys]
    return {record.key: record for record, _ in results}, sum(ran for _, ran in results)


def run_joblib(task: Task, keys: Sequence[str], n_jobs: int) -> Outcome:
    """Evaluate the keys in ``n_jobs`` local worker processes (joblib's loky backend).

    Each worker commits its result to the store itself, so a result is durable even if this
    process dies before collecting it.
    """
    try:
        results = joblib.Parallel(n_jobs=n_jobs, batch_size=1)(
            joblib.delayed(_run_and_save)(task, key) for key in keys
        )
    except TerminatedWorkerError as exc:  # a model run killed its process (segfault, OOM)
        logger.warning("a worker process died (%s); running the rest one worker at a time", exc)
        return _run_isolated(task, keys)
    return {record.key: record for record, _ in results}, sum(ran for _, ran in results)


def _run_isolated(task: Task, keys: Sequence[str]) -> Outcome:
    """Each key in a worker process of its own; a key whose worker dies is a failed evaluation.

    Results the crashed batch already committed are found in the store and not run again.
    """
    records: dict[str, Record] = {}
    calls = 0
    for key in keys:
        try:
            [(record, ran)] = joblib.Parallel(n_jobs=2, batch_size=1)([joblib.delayed(_run_and_save)(task, key)])
        except TerminatedWorkerError as exc:
            record, ran = failed_record(task, key, f"worker process died: {exc}", repr(exc)), 1
            if task.store is not None:
                task.store.save(record)
        records[key] = record
        calls += ran
    return records, calls


def failed_record(task: Task, key: str, error: str, traceback: str) -> Record:
    """A failed evaluation of ``key`` whose model call ended without a result."""
    return Record(
        model=task.identity, key=key, status="failed", outputs=None, error=error,
        wall_time=float("nan"), finished_at=now_utc(), host=socket.gethostname(), pid=os.getpid(),
        traceback=traceback,
    )


def run_submitit(task: Task, keys: Sequence[str], executor: Any) -> Outcome:
    """Evaluate the keys as one submitit job array (one job per θp) and wait for them.

    Jobs deposit their result in the store's spool folder; this process ingests the folder
    after each job. A job that dies without a result (time limit, out of memory, node failure)
    is recorded as a failed evaluation with the scheduler's error.
    """
    jobs = executor.map_array(functools.partial(_run_and_deposit, task), list(keys))
    logger.info("submitted %d evaluations of %s as jobs %s", len(jobs), task.identity,
                ", ".join(str(job.job_id) for job in jobs[:3]) + (" ..." if len(jobs) > 3 else ""))
    records: dict[str, Record] = {}
    for key, job in zip(keys, jobs):
        try:
            record = job.result()
        except Exception as exc:  # the job itself failed; the model call may never have run
            record = failed_record(task, key, f"job {job.job_id} failed: {_job_error(exc)}", str(exc))
        if task.store is not None:
            task.store.ingest()
            task.store.save(record)
        records[key] = record
    return records, len(jobs)


def _job_error(exc: BaseException) -> str:
    """Short cause of a failed submitit job: the trace's last line, or the first two lines."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    if isinstance(exc, submitit.core.utils.FailedJobError) and lines:
        return f"{type(exc).__name__}: {lines[-1]}"
    return f"{type(exc).__name__}: {' '.join(lines[:2])}"


def _run_and_save(task: Task, key: str) -> tuple[Record, bool]:
    """Run one key unless the store got it meanwhile; returns the record and whether it ran.

    With a store, the key is claimed first (:mod:`torchshm.storage.claims`): if another process
    is running it, this one waits for that result instead of running the model again.
    """
    store = task.store
    if store is None:
        with watch_owner(task.owner):
            return run_model(task.model, task.identity, key, key_theta(key), task.shape), True
    found = store.lookup(task.identity, [key]).get(key)
    if found is not None and (found.ok or not task.retry_failed):
        return found, False
    if claims.wait_for_claim(store, task.identity, key, not task.retry_failed) == "done":
        found = store.lookup(task.identity, [key]).get(key)
        if found is not None:
            return found, False
    record = None
    try:
        with watch_owner(task.owner):
            record = run_model(task.model, task.identity, key, key_theta(key), task.shape)
    finally:  # a signal landing just after the run still lets the finished run be kept
        if record is not None:
            store.save(record)
        claims.release(store, task.identity, key)
    return record, True


def _run_and_deposit(task: Task, key: str) -> Record:
    record = run_model(task.model, task.identity, key, key_theta(key), task.shape)
    if task.store is not None:
        task.store.deposit(record)
    return record
