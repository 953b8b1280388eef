"""Running the missing evaluations on any executor with ``submit``: Dask, ``concurrent.futures``.

The executor gets one task per θp (``executor.submit(fn, task, key)``; a Dask client's
``submit(..., pure=False)``) and returns a future with ``done()`` and ``result()``. The worker
runs the model and returns the record; this process stores each record as soon as its future is
done, so workers need no access to the store (a Dask worker on another machine cannot open the
SQLite file). A worker that can reach the store's folder (same host or a shared file system)
also deposits the record in the store's spool as soon as the run ends, and looks there before
running: a result that finished on a worker killed before this process collected it is taken
from the spool when Dask runs the task again, not computed twice. Before submitting, this process claims each θp in the store
(:mod:`torchshm.storage.claims`), so that another study sharing the store does not run it too;
a θp that another live process is running is waited for, then taken from the store.

A worker that dies during a run: Dask runs the task again on another worker (up to its
``distributed.scheduler.allowed-failures``, 3 by default), then raises ``KilledWorker``; a
``ProcessPoolExecutor`` raises ``BrokenProcessPool`` for every run it had not finished. A θp
whose task Dask gave up on is stored as a failed evaluation with that error
(``retry_failed=True`` runs it again); the runs of a broken pool are failed in the result but
not stored, so the next call runs them. Every finished result is kept.
"""

from __future__ import annotations

import dataclasses
import logging
import time
import traceback
from concurrent.futures import BrokenExecutor, CancelledError
from collections.abc import Sequence
from typing import Any

from torchshm.storage import claims, spool
from torchshm.storage.keys import key_theta
from torchshm.storage.record import Record, error_text, run_model
from torchshm.storage.runners import Outcome, Task, failed_record
from torchshm.storage.watchdog import watch_owner

logger = logging.getLogger(__name__)

#: largest pause [s] between two looks at the futures
MAX_POLL_S = 0.5


def is_dask_client(executor: object) -> bool:
    """Whether ``executor`` is a ``distributed.Client``."""
    return type(executor).__module__.split(".")[0] == "distributed" and hasattr(executor, "scheduler_info")


def check_executor(executor: object) -> None:
    """Refuse an object that has neither ``submit`` (futures) nor ``map_array`` (submitit)."""
    if not callable(getattr(executor, "submit", None)) and not callable(getattr(executor, "map_array", None)):
        raise ValueError(
            f"executor must have submit(fn, *args) returning futures (concurrent.futures, "
            f"dask.distributed.Client) or be a submitit executor, got {type(executor).__name__}"
        )


def run_futures(task: Task, keys: Sequence[str], executor: Any) -> Outcome:
    """Evaluate the keys as one task each on ``executor``; each result stored when it is done.

    Returns:
        key -> record, and the number of model runs submitted.
    """
    store = task.store
    remote = dataclasses.replace(task, store=None, spool=None if store is None else store.spool_folder)
    records: dict[str, Record] = {}
    mine, held = _claim_all(task, keys, records)
    calls = 0
    try:
        calls += _collect(task, _submit_all(executor, remote, mine), records)
        if held:
            again = []
            for key in held:  # run by another process: wait for its result, or take it over
                if claims.wait_for_claim(store, task.identity, key, not task.retry_failed) == "done":
                    records[key] = store.lookup(task.identity, [key])[key]
                else:
                    again.append(key)
            mine += again
            calls += _collect(task, _submit_all(executor, remote, again), records)
    finally:
        if store is not None:
            for key in mine:
                if key not in records:
                    claims.release(store, task.identity, key)
    return records, calls


def _claim_all(task: Task, keys: Sequence[str], records: dict[str, Record]) -> tuple[list[str], list[str]]:
    """Keys to submit now, and keys another live process is running; ``done`` ones go to
    ``records``."""
    if task.store is None:
        return list(keys), []
    mine, held = [], []
    for key in keys:
        outcome = claims.claim(task.store, task.identity, key, not task.retry_failed)
        if outcome == "done":
            records[key] = task.store.lookup(task.identity, [key])[key]
        else:
            (held if outcome == "held" else mine).append(key)
    return mine, held


def _submit_all(executor: Any, task: Task, keys: Sequence[str]) -> dict[Any, str]:
    """Submit one task per key; future -> key."""
    options = {"pure": False} if is_dask_client(executor) else {}
    futures = {executor.submit(run_remote, task, key, **options): key for key in keys}
    if futures:
        logger.info("submitted %d evaluations of %s to %s", len(futures), task.identity,
                    type(executor).__name__)
    return futures


def _collect(task: Task, futures: dict[Any, str], records: dict[str, Record]) -> int:
    """Wait for every future, storing each record as soon as its future is done.

    ``futures`` is emptied as they are done: a Dask future no longer held is released, so a
    worker lost later does not make Dask run its finished tasks again.
    """
    pending, pause, n_futures = futures, 0.01, len(futures)
    try:
        while pending:
            done = [future for future in pending if future.done()]
            if not done:
                time.sleep(pause)
                pause = min(2.0 * pause, MAX_POLL_S)
                continue
            pause = 0.01
            for future in done:
                key = pending.pop(future)
                records[key], keep = _outcome(task, key, future)
                if callable(getattr(future, "release", None)):
                    future.release()
                if task.store is not None:
                    if keep:
                        task.store.save(records[key])
                    claims.release(task.store, task.identity, key)
    finally:
        for future in pending:  # interrupted: runs not started yet are not started
            future.cancel()
    return n_futures


def _outcome(task: Task, key: str, future: Any) -> tuple[Record, bool]:
    """The future's record and whether to store it. A task the executor itself lost (a broken
    process pool, a cancelled future) gives a failed record that is not stored: it may never
    have run, and the next call runs it."""
    try:
        return future.result(), True
    except Exception as exc:  # the model call itself never raises: the worker failed
        logger.warning("evaluation of %s at θp=[%s] lost its worker: %s", task.identity, key,
                       error_text(exc))
        lost = isinstance(exc, (BrokenExecutor, CancelledError)) or type(exc).__name__ == "CancelledError"
        record = failed_record(task, key, f"worker failed: {error_text(exc)}", traceback.format_exc())
        return record, not lost


def run_remote(task: Task, key: str) -> Record:
    """Run one key in a worker and return its record (the caller stores it).

    Where the worker reaches the store's spool folder, a record of this key already deposited
    there (a run whose result was lost with its worker before it was collected) is returned
    without running the model, and a new record is deposited there before it is returned.
    """
    folder = task.spool if task.spool is not None and task.spool.parent.is_dir() else None
    if folder is not None:
        found = spool.find(folder, task.identity, key)
        if found is not None and (found.ok or not task.retry_failed):
            return found
    with watch_owner(task.owner):
        record = run_model(task.model, task.identity, key, key_theta(key), task.shape)
    if folder is not None:
        try:
            spool.deposit(folder, record)
        except OSError as exc:  # the caller still stores the record it receives
            logger.warning("cannot deposit the run at θp=[%s] in %s: %s", key, folder, exc)
    return record


__all__ = ["check_executor", "is_dask_client", "run_futures", "run_remote"]
