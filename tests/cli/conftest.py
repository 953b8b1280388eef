"""Running ``torchshm-identify`` as a user would: a subprocess in a scratch directory."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Callable

import pytest

from tests.cli import zygote

REPO = Path(__file__).resolve().parents[2]
#: the installed console script, next to the interpreter running the tests
CONSOLE_SCRIPT = Path(sys.executable).with_name("torchshm-identify")


def run_cli(args: list[str], cwd: Path, script: bool = False, env: dict[str, str] | None = None,
            timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """Run ``torchshm-identify args`` (or ``python scripts/identify.py args``) in ``cwd``: the
    console script forked from a process that has imported it (:mod:`tests.cli.zygote`; the
    same process, files and exit status without 3-6 s of imports), the script as a subprocess."""
    command = [sys.executable, str(REPO / "scripts" / "identify.py")] if script else [str(CONSOLE_SCRIPT)]
    full_env = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    full_env.update({"OMP_NUM_THREADS": "1", **(env or {})})
    if not script and zygote.enabled():
        return zygote.run(command + args, cwd, full_env, timeout)
    return subprocess.run(command + args, cwd=cwd, env=full_env, capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture
def cli(tmp_path: Path) -> Callable[..., subprocess.CompletedProcess[str]]:
    """``cli(*args, script=False, env=None)`` runs the application in ``tmp_path``."""
    assert CONSOLE_SCRIPT.is_file(), "torchshm-identify is not installed: run scripts/install.sh"
    return lambda *args, **kw: run_cli(list(args), tmp_path, **kw)
