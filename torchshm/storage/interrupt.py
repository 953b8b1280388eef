"""Stopping a long run on SIGTERM or Ctrl-C: at once, keeping every finished model run.

Slurm sends SIGTERM on pre-emption and at the time limit; a user presses Ctrl-C (SIGINT).
Every finished model run is already committed to the evaluation store, so stopping loses
nothing but the runs in flight. :func:`resumable` turns SIGTERM into the same exception as
Ctrl-C (:class:`Interrupted`, a ``KeyboardInterrupt``), so that ``finally`` blocks run (the
TensorBoard trace is closed, joblib workers are stopped), and prints one line on stderr
saying what is kept and how to resume. After SIGTERM the process then exits with status 143
(128 + 15), as the default SIGTERM action would; Ctrl-C propagates as ``KeyboardInterrupt``.

Blocks nest: only the outermost prints, so the command-line tool can give its own resume
line ("run the same command again") around library calls that have theirs.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

#: exit status after SIGTERM (the shell's 128 + signal number)
EXIT_SIGTERM = 128 + signal.SIGTERM
#: exit status after Ctrl-C
EXIT_SIGINT = 128 + signal.SIGINT

_depth = 0


class Interrupted(KeyboardInterrupt):
    """Raised in the main thread when the process receives SIGTERM inside :func:`resumable`.

    Attributes:
        signum: the signal number (``signal.SIGTERM``).
    """

    def __init__(self, signum: int) -> None:
        super().__init__(f"received {signal.Signals(signum).name}")
        self.signum = signum


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    raise Interrupted(signum)


def resume_line(what: str, store: str | Path | None, how: str | None, signame: str) -> str:
    """The one line printed after an interruption (see :func:`resumable`)."""
    if store is None:
        return (f"{what} stopped by {signame}; no evaluation store was given, so its model runs "
                f"are not kept (give a store to make a run resumable)")
    how = how or "call it again with the same store"
    return (f"{what} stopped by {signame}; every finished model run is kept in {store}; "
            f"to resume, {how}")


@contextlib.contextmanager
def resumable(what: str, store: str | Path | None, how: str | None = None) -> Iterator[None]:
    """Within the block, SIGTERM and Ctrl-C stop the run at once with one line on stderr.

    Args:
        what: the run, as the line names it (e.g. ``"identify (vbmc)"``).
        store: the evaluation store the run writes to, or None.
        how: how to resume (default ``"call it again with the same store"``).

    Raises:
        KeyboardInterrupt: after Ctrl-C (re-raised after the line is printed).
        SystemExit: status 143 after SIGTERM (outermost block only; inner ones re-raise
            :class:`Interrupted`).

    Outside the main thread signal handlers cannot be set; the block then only prints the
    line on ``KeyboardInterrupt``.
    """
    global _depth
    outermost = _depth == 0
    previous = None
    if outermost and threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    _depth += 1
    try:
        yield
    except KeyboardInterrupt as exc:
        if not outermost:
            raise
        signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
        line = resume_line(what, store, how, signal.Signals(signum).name)
        print(line, file=sys.stderr, flush=True)
        if isinstance(exc, Interrupted):
            raise SystemExit(EXIT_SIGTERM) from None
        raise
    finally:
        _depth -= 1
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def store_of(problem: object) -> Path | None:
    """Path of a problem's (or a call's) evaluation store, or None."""
    store = getattr(problem, "store", problem)
    if store is None:
        return None
    path = getattr(store, "path", store)
    return Path(path) if isinstance(path, (str, Path)) else None


__all__ = ["EXIT_SIGINT", "EXIT_SIGTERM", "Interrupted", "resumable", "resume_line", "store_of"]
