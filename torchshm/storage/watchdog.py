"""Workers that stop when the study that owns them dies.

A worker process (joblib's loky workers, a Dask worker on the same machine) runs model runs
for the process that called :func:`torchshm.storage.evaluate`, its *owner*. If the owner is
killed (``kill -9``, out of memory), nobody will collect the worker's results: loky workers
would go on with the run in hand (10 minutes of FE, or hours) and wait for more. While a
worker runs a model for an owner on the same machine, a watchdog thread looks at the owner
every :data:`POLL_S` seconds (its process id and start time, as claims do; for a worker that
the owner started, for the worker's whole life); once the owner is gone, it stops the run's
programs (:func:`torchshm.forward.processes.kill_children`) and ends
the worker process. The run leaves no result and no live claim, so the next ``evaluate`` on the
store runs it again; finished runs are in the store already.

An owner on another machine (a Dask cluster, Slurm) is not watched: there the scheduler's own
rules apply (a Dask worker stops its tasks when their client is gone for good; Slurm jobs run
to their end and their results are kept, see ``docs/parallel.md``).
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import threading
from collections.abc import Iterator
from dataclasses import dataclass

from torchshm.forward import processes
from torchshm.storage.claims import _start_token

logger = logging.getLogger(__name__)

#: seconds between two looks at the owner
POLL_S = 0.5
#: exit status of a worker that ended because its owner died
EXIT_OWNER_GONE = 70


@dataclass(frozen=True)
class Owner:
    """The process a worker runs models for.

    Attributes:
        host: its host name.
        pid: its process id.
        started: its start time in clock ticks since boot ('' where unknown).
    """

    host: str
    pid: int
    started: str

    @classmethod
    def this_process(cls) -> Owner:
        """The calling process as an owner."""
        pid = os.getpid()
        return cls(socket.gethostname(), pid, _start_token(pid))

    def watchable(self) -> bool:
        """Whether a process here can tell if the owner is alive (same host, another process)."""
        return self.host == socket.gethostname() and self.pid != os.getpid() and bool(self.started)

    def alive(self) -> bool:
        """Whether the owner still runs (always True for an owner that is not watchable)."""
        return not self.watchable() or _start_token(self.pid) == self.started


class _Watchdog:
    """One thread per worker process, watching the owners of the runs in progress."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.owners: dict[Owner, int] = {}
        self.thread: threading.Thread | None = None
        self.wake = threading.Event()
        self.fired = threading.Event()

    def add(self, owner: Owner) -> None:
        with self.lock:
            self.owners[owner] = self.owners.get(owner, 0) + 1
            if self.thread is None or not self.thread.is_alive():
                self.thread = threading.Thread(target=self._run, name="torchshm-watchdog", daemon=True)
                self.thread.start()

    def remove(self, owner: Owner) -> None:
        with self.lock:
            if owner.pid == os.getppid():  # a worker of its parent: watched while it lives
                return
            self.owners[owner] -= 1
            if not self.owners[owner]:
                del self.owners[owner]

    def _run(self) -> None:
        while not self.wake.wait(POLL_S):
            with self.lock:
                owners = list(self.owners)
            gone = next((owner for owner in owners if not owner.alive()), None)
            if gone is not None:
                logger.warning("process %d that owns this worker is gone; stopping its runs and "
                               "this worker (pid %d)", gone.pid, os.getpid())
                self.fired.set()  # from now on no run of this process ends (see watch_owner)
                processes.kill_children()
                os._exit(EXIT_OWNER_GONE)


_WATCHDOG = _Watchdog()


@contextlib.contextmanager
def watch_owner(owner: Owner | None) -> Iterator[None]:
    """While the block runs, end this process (and its programs) if ``owner`` dies.

    Nothing is watched for None, for the owner itself, or for an owner on another host. An
    owner that is this process's parent (loky workers, the workers of a Dask ``LocalCluster``)
    stays watched after the block: an idle worker also ends when its owner dies.
    """
    if owner is None or not owner.watchable():
        yield
        return
    _WATCHDOG.add(owner)
    try:
        yield
    finally:
        if _WATCHDOG.fired.is_set():  # the run ended because its programs were killed:
            threading.Event().wait()  # keep its result out of the store until the exit
        _WATCHDOG.remove(owner)


__all__ = ["EXIT_OWNER_GONE", "POLL_S", "Owner", "watch_owner"]
