"""``torchshm-identify`` commands forked from a process that has already imported it.

Starting the console script costs 3-6 s of imports (torch, Hydra, the library) before the
command reads its first argument; the CLI tests run about sixty commands, most of them refused
in well under a second once imported. Each command here is a child forked from one server
process per test process (``multiprocessing``'s forkserver, with ``torchshm.cli.identify``
preloaded, which runs no torch operation, so no thread pool is forked): its own process, its
own working folder, environment, stdout, stderr and exit status, the Python path of the console
script (its folder and ``PYTHONPATH``, not the test's), and the exit handlers run as at the end
of a real run. ``TORCHSHM_TEST_SUBPROCESS=1`` runs every command as a real subprocess instead.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import subprocess
import sys
import tempfile
import threading
import traceback
from pathlib import Path

_CONTEXT: multiprocessing.context.ForkServerContext | None = None


def enabled() -> bool:
    """Whether commands are forked (``forkserver`` among :func:`multiprocessing.get_all_start_methods`
    and not turned off by ``TORCHSHM_TEST_SUBPROCESS=1``)."""
    return (os.environ.get("TORCHSHM_TEST_SUBPROCESS") != "1"
            and "forkserver" in multiprocessing.get_all_start_methods())


def run(command: list[str], cwd: Path, env: dict[str, str],
        timeout: float) -> subprocess.CompletedProcess[str]:
    """Run ``command`` (the console script, then its arguments) as a forked child.

    Raises:
        subprocess.TimeoutExpired: as :func:`subprocess.run` does, the child killed.
    """
    global _CONTEXT
    if _CONTEXT is None:
        _CONTEXT = multiprocessing.get_context("forkserver")
        _CONTEXT.set_forkserver_preload(["torchshm.cli.identify"])
    with tempfile.TemporaryDirectory() as tmp:
        out, err = Path(tmp) / "stdout", Path(tmp) / "stderr"
        child = _CONTEXT.Process(target=_main, args=(command, str(cwd), env, str(out), str(err)))
        child.start()
        child.join(timeout)
        if child.is_alive():
            child.kill()
            child.join()
            raise subprocess.TimeoutExpired(command, timeout, out.read_text(), err.read_text())
        code = child.exitcode if child.exitcode is not None else -9
        return subprocess.CompletedProcess(command, code, out.read_text(), err.read_text())


def _main(command: list[str], cwd: str, env: dict[str, str], out: str, err: str) -> None:
    """In the child: the console script's environment, then ``main(arguments)``."""
    for fd, path in ((1, out), (2, err)):
        target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(target, fd)
        os.close(target)
    os.chdir(cwd)
    os.environ.clear()
    os.environ.update(env)
    base = [p for p in sys.path if p.startswith((sys.prefix, sys.base_prefix)) and p]
    extra = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    sys.path[:] = [str(Path(command[0]).parent), *extra, *base]
    sys.argv = list(command)
    import torch

    if env.get("OMP_NUM_THREADS", "").isdigit():
        torch.set_num_threads(int(env["OMP_NUM_THREADS"]))
    from torchshm.cli.identify import main

    code = 0
    try:
        main(command[1:])
    except SystemExit as stop:
        code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
        if stop.code is not None and not isinstance(stop.code, int):
            print(stop.code, file=sys.stderr)
    except BaseException:  # as the interpreter would: the traceback on stderr, status 1
        traceback.print_exc()
        code = 1
    # as the interpreter ends: non-daemon threads and their hooks (loky's executor shuts its
    # workers down there), then the atexit handlers
    threading._shutdown()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
