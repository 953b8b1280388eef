"""Claims: one process at a time runs a given θp, however many processes share a store.

Before a model run, the process that is about to run θp writes a claim (model, key, host,
process id, process start time) in the store's ``claims`` table, in the same transaction that
checks that the store does not hold the result yet. Another process that wants the same θp
meanwhile finds the claim and waits for the result instead of running the model a second
time. The claim is removed when the result is stored, or when the run fails.

A claim whose process is gone (killed with SIGKILL, a node lost) must not block anyone: on the
claim's own host, a claim is live while a process with that id and that start time exists
(``/proc/<pid>/stat``; elsewhere ``os.kill(pid, 0)``); a claim from another host is taken
over after :data:`STALE_AFTER_S` seconds. A waiting process takes over a dead claim and runs
the model itself.

If the store cannot be written (locked for longer than its timeout, read-only, disk full), a
claim cannot be taken: the run goes ahead unclaimed (a duplicate run is better than none) and
its result goes to the spool as before.
"""

from __future__ import annotations

import logging
import os
import socket
import sqlite3
import time
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from torchshm.storage.store import EvaluationStore

logger = logging.getLogger(__name__)

#: seconds after which a claim by a process on another host is taken over
STALE_AFTER_S = 6 * 3600.0
#: first and largest pause [s] between two looks at a claimed θp
POLL_S = (0.05, 2.0)

Outcome = Literal["mine", "done", "held", "unclaimed"]


def _start_token(pid: int) -> str:
    """The start time of process ``pid`` in clock ticks since boot ('' where unknown)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()
        return fields[19].decode()
    except (OSError, IndexError):
        return ""


def _alive(host: str, pid: int, started: str, claimed_at: float) -> bool:
    """Whether the process that wrote a claim may still be running the model."""
    if host != socket.gethostname():
        return time.time() - claimed_at < STALE_AFTER_S
    if started:
        return _start_token(pid) == started
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def claim(store: EvaluationStore, model: str, key: str, accept_failed: bool) -> Outcome:
    """Try to claim ``key`` of ``model`` for this process.

    Args:
        store: the shared evaluation store.
        model: the model's identity.
        key: the canonical θp key.
        accept_failed: whether a stored failed evaluation counts as done.

    Returns:
        ``"mine"`` (claimed: run the model, then :func:`release`), ``"done"`` (the store holds
        the result now), ``"held"`` (a live process is running it: wait) or ``"unclaimed"``
        (the store cannot be written: run without a claim).
    """
    pid = os.getpid()
    try:
        with store._connect() as con:
            con.execute("BEGIN IMMEDIATE")
            try:
                status = con.execute(
                    "SELECT status FROM evaluations WHERE model = ? AND theta_key = ?", (model, key)
                ).fetchone()
                if status is not None and (status[0] == "ok" or accept_failed):
                    return "done"
                holder = con.execute(
                    "SELECT host, pid, started, claimed_at FROM claims "
                    "WHERE model = ? AND theta_key = ?", (model, key)
                ).fetchone()
                ours = holder is not None and holder[0] == socket.gethostname() and holder[1] == pid
                if holder is not None and not ours and _alive(*holder):
                    return "held"
                con.execute(
                    "INSERT OR REPLACE INTO claims VALUES (?, ?, ?, ?, ?, ?)",
                    (model, key, socket.gethostname(), pid, _start_token(pid), time.time()),
                )
                return "mine"
            finally:
                con.execute("COMMIT")
    except sqlite3.Error as exc:
        logger.debug("%s: cannot claim %s (%s); running it unclaimed", store, key, exc)
        return "unclaimed"


def release(store: EvaluationStore, model: str, key: str) -> None:
    """Remove this process's claim on ``key`` (nothing if it holds none or the store is locked)."""
    try:
        with store._connect() as con:
            con.execute(
                "DELETE FROM claims WHERE model = ? AND theta_key = ? AND host = ? AND pid = ?",
                (model, key, socket.gethostname(), os.getpid()),
            )
    except sqlite3.Error as exc:  # a stale claim of a live process only delays its waiters
        logger.debug("%s: cannot release the claim on %s (%s)", store, key, exc)


def wait_for_claim(store: EvaluationStore, model: str, key: str, accept_failed: bool) -> Outcome:
    """Claim ``key``, waiting while another live process holds it.

    Returns:
        ``"mine"``, ``"done"`` or ``"unclaimed"`` (never ``"held"``).
    """
    pause, logged = POLL_S[0], False
    while True:
        outcome = claim(store, model, key, accept_failed)
        if outcome != "held":
            return outcome
        if not logged:
            logger.info("θp %s is being run by another process on %s; waiting for its result",
                        key, store.path)
            logged = True
        time.sleep(pause)
        pause = min(2.0 * pause, POLL_S[1])


def held(store: EvaluationStore) -> list[tuple[str, str, str, int]]:
    """Claims in the store: (model, key, host, pid) for each, live or not."""
    try:
        with store._connect() as con:
            return [tuple(row) for row in con.execute("SELECT model, theta_key, host, pid FROM claims")]
    except sqlite3.Error:
        return []


__all__ = ["STALE_AFTER_S", "claim", "held", "release", "wait_for_claim"]
