"""Running the missing evaluations of a batch: in process, with joblib, or with submitit.

Each runner calls the model once per parameter vector and hands every result to the store as
soon as it exists, from the process that ran it: in process and with joblib the worker
commits to the SQLite file itself; a submitit job (possibly on another machine) deposits its
result in the store's spool folder. Scheduling is left to joblib and submitit.
"""

from __future__ import annotations

import functools
import logging
import os
import socket
from collections.abc import Sequence
from typing import Any

import joblib
import submitit

from torchshm.storage.keys import key_theta
from torchshm.storage.record import Record, error_text, now_utc, run_model
from torchshm.storage.store import EvaluationStore

logger = logging.getLogger(__name__)


def run_serial(
    model: Any, identity: str, shape: tuple[int, int], keys: Sequence[str],
    store: EvaluationStore | None,
) -> dict[str, Record]:
    """Evaluate one key after the other in this process, committing each result at once."""
    return {key: _run_and_put(model, identity, shape, key, store) for key in keys}


def run_joblib(
    model: Any, identity: str, shape: tuple[int, int], keys: Sequence[str],
    store: EvaluationStore | None, n_jobs: int,
) -> dict[str, Record]:
    """Evaluate the keys in ``n_jobs`` local worker processes (joblib's loky backend).

    Each worker commits its result to the store itself, so a result is durable even if this
    process dies before collecting it.
    """
    task = joblib.delayed(_run_and_put)
    records = joblib.Parallel(n_jobs=n_jobs, batch_size=1)(
        task(model, identity, shape, key, store) for key in keys
    )
    return {record.key: record for record in records}


def run_submitit(
    model: Any, identity: str, shape: tuple[int, int], keys: Sequence[str],
    store: EvaluationStore | None, executor: Any,
) -> dict[str, Record]:
    """Evaluate the keys as one submitit job array (one job per θp) and wait for them.

    Jobs deposit their result in the store's spool folder; this process ingests the folder
    after each job. A job that dies without a result (time limit, out of memory, node failure)
    is recorded as a failed evaluation with the scheduler's error.
    """
    task = functools.partial(_run_and_deposit, model, identity, shape, store=store)
    jobs = executor.map_array(task, list(keys))
    logger.info("submitted %d evaluations of %s as jobs %s", len(jobs), identity,
                ", ".join(str(job.job_id) for job in jobs[:3]) + (" ..." if len(jobs) > 3 else ""))
    records: dict[str, Record] = {}
    for key, job in zip(keys, jobs):
        try:
            record = job.result()
        except Exception as exc:  # the job itself failed; the model call may never have run
            record = Record(
                model=identity, key=key, status="failed", outputs=None,
                error=f"job {job.job_id} failed: {_job_error(exc)}",
                wall_time=float("nan"),
                finished_at=now_utc(), host=socket.gethostname(), pid=os.getpid(),
                traceback=error_text(exc),
            )
        if store is not None:
            store.ingest()
            store.put(record)
        records[key] = record
    return records


def _job_error(exc: BaseException) -> str:
    """Short cause of a failed submitit job: the trace's last line, or the first two lines."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    if isinstance(exc, submitit.core.utils.FailedJobError) and lines:
        return f"{type(exc).__name__}: {lines[-1]}"
    return f"{type(exc).__name__}: {' '.join(lines[:2])}"


def _run_and_put(
    model: Any, identity: str, shape: tuple[int, int], key: str, store: EvaluationStore | None
) -> Record:
    record = run_model(model, identity, key, key_theta(key), shape)
    if store is not None:
        store.put(record)
    return record


def _run_and_deposit(
    model: Any, identity: str, shape: tuple[int, int], key: str, store: EvaluationStore | None
) -> Record:
    record = run_model(model, identity, key, key_theta(key), shape)
    if store is not None:
        store.deposit(record)
    return record
