"""One run of an external program in its work folder, that never outlives the run.

:func:`run_program` starts the command in a session of its own (so its whole process group can
be stopped), with its output in ``run.log`` and a cap on the size of any file it writes,
registers the group with :mod:`torchshm.forward.processes` while it runs, and stops the group
(SIGTERM, then SIGKILL) on a timeout or an interruption.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from torchshm.forward import processes
from torchshm.forward.files import LOG_FILE


class ExternalModelError(RuntimeError):
    """An external program run failed: exit status, timeout or unusable output."""


def run_program(command: str | Sequence[str], folder: Path, env: Mapping[str, str],
                timeout: float | None, kill_grace: float, max_output_bytes: int | None) -> int:
    """Run ``command`` in ``folder`` (output to ``run.log``) and return its exit status.

    Raises:
        ExternalModelError: when it cannot start, or runs over ``timeout`` seconds (it is
            then killed with its process group).
    """
    shell = isinstance(command, str)
    with open(folder / LOG_FILE, "wb") as log:
        try:
            process = subprocess.Popen(
                command, cwd=folder, stdout=log, stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL, shell=shell, env=dict(env), start_new_session=True,
                # killed with its worker (torchshm.forward.processes)
                preexec_fn=processes.child_setup(_file_size_limit(max_output_bytes)),
            )
        except OSError as exc:
            raise ExternalModelError(f"cannot start {command!r}: {exc}") from None
        processes.track(process.pid)  # its group, stopped if the study dies
        try:
            return process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            _kill_group(process, kill_grace)
            raise ExternalModelError(
                f"program timed out after {timeout:g} s and was killed (work folder {folder})"
            ) from None
        finally:
            if process.poll() is None:  # interrupted while waiting: leave no orphan run
                _kill_group(process, kill_grace)
            processes.untrack(process.pid)


def _file_size_limit(limit: int | None) -> Any:
    """A ``preexec_fn`` capping the size of any file the program writes at ``limit`` bytes."""
    if limit is None:
        return None

    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def _kill_group(process: subprocess.Popen, grace: float) -> None:
    """SIGTERM the run's process group, SIGKILL it after ``grace`` seconds, reap the leader."""
    _signal_group(process.pid, signal.SIGTERM)
    try:
        process.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        pass
    _signal_group(process.pid, signal.SIGKILL)  # also whatever the leader left behind
    process.wait()


def _signal_group(group: int, sig: signal.Signals) -> None:
    try:
        os.killpg(group, sig)
    except (ProcessLookupError, PermissionError):
        pass


def log_tail(path: Path, n_chars: int = 300) -> str:
    """Last line(s) of a log file, at most ``n_chars`` characters."""
    try:
        text = path.read_bytes()[-n_chars:].decode(errors="replace").strip()
    except OSError:
        return ""
    return " | ".join(line.strip() for line in text.splitlines() if line.strip())
