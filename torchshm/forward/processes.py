"""Child processes of model runs that never outlive the run that started them.

A finite element program started by a worker process must stop when that worker stops, or
when the study that owns the worker dies (``kill -9``, a lost node): otherwise it keeps a
licence and the cores busy for hours. Two mechanisms, both used by
:class:`~torchshm.forward.ExternalModel`:

* on Linux the program is started with ``PR_SET_PDEATHSIG`` (``prctl``, through ctypes): the
  kernel sends it SIGKILL when the worker thread that started it exits, however the worker
  ends;
* its process group (each run is a session of its own) is registered here while it runs, so
  that :func:`kill_children` (called by the owner watchdog,
  :mod:`torchshm.storage.watchdog`) stops the program and whatever it started;
* the groups are also told to a small guard process (one per process that runs programs)
  through a pipe; when the pipe closes because its process died, however it died (a Dask
  worker ends at once when its nanny goes), the guard kills the groups still registered, so
  the programs the program started go too.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

_PR_SET_PDEATHSIG = 1
_groups: set[int] = set()
_lock = threading.Lock()


def _prctl() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).prctl
    except (OSError, AttributeError):
        return None


_PRCTL = _prctl()


def child_setup(*steps: Callable[[], None] | None) -> Callable[[], None]:
    """A ``preexec_fn`` that runs ``steps`` (None ones skipped), then asks the kernel to kill
    the child with SIGKILL when its parent thread exits (Linux; elsewhere nothing more)."""

    def setup() -> None:
        for step in steps:
            if step is not None:
                step()
        if _PRCTL is not None:
            _PRCTL(_PR_SET_PDEATHSIG, signal.SIGKILL)

    return setup


#: the guard: reads "+group" / "-group" lines; at end of input kills the groups left
_GUARD = """
import os, signal, sys, time
groups = set()
for line in sys.stdin:
    (groups.add if line[0] == "+" else groups.discard)(int(line[1:]))
for sig in (signal.SIGTERM, signal.SIGKILL):
    for group in groups:
        try:
            os.killpg(group, sig)
        except OSError:
            pass
    if groups and sig == signal.SIGTERM:
        time.sleep(2.0)
"""
_guard: dict[int, subprocess.Popen] = {}  # pid of this process -> its guard


def _tell_guard(line: str) -> None:
    """Send one line to this process's guard, starting it first (called under ``_lock``)."""
    guard = _guard.get(os.getpid())
    if guard is None or guard.poll() is not None:
        try:
            guard = subprocess.Popen([sys.executable, "-S", "-c", _GUARD], stdin=subprocess.PIPE,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     start_new_session=True, text=True)
        except OSError:
            return
        _guard[os.getpid()] = guard
    try:
        guard.stdin.write(line + "\n")
        guard.stdin.flush()
    except OSError:
        pass


def track(group: int) -> None:
    """Register the process group ``group`` of a running program (see :func:`kill_children`)."""
    with _lock:
        _groups.add(group)
        _tell_guard(f"+{group}")


def untrack(group: int) -> None:
    """Forget the process group ``group`` (its program has ended)."""
    with _lock:
        _groups.discard(group)
        _tell_guard(f"-{group}")


def _child_pids(parent: int) -> list[int]:
    """Processes whose parent is ``parent`` (from ``/proc``; empty where there is none)."""
    children = []
    try:
        entries = os.listdir("/proc")
    except OSError:
        return []
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as stat:
                fields = stat.read().rsplit(b")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == parent:
            children.append(int(entry))
    return children


def kill_children(grace: float = 2.0) -> None:
    """Stop every registered program group and every child process of this process.

    SIGTERM first; whatever still runs after ``grace`` seconds gets SIGKILL.
    """
    with _lock:
        groups = set(_groups)
    children = _child_pids(os.getpid())
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for group in groups:
            _signal(os.killpg, group, sig)
        for pid in children:
            _signal(os.kill, pid, sig)
        if sig == signal.SIGTERM and (groups or children):
            time.sleep(grace)


def _signal(send: Callable[[int, int], None], target: int, sig: int) -> None:
    try:
        send(target, sig)
    except (ProcessLookupError, PermissionError):
        pass


__all__ = ["child_setup", "kill_children", "track", "untrack"]
