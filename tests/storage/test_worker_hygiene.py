"""kill -9 of the process that evaluates through a store: its workers and their FE programs
are gone within 10 s, and a resume runs only what had not finished."""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from torchshm import ExternalModel
from torchshm.storage import EvaluationStore, evaluate

HERE = Path(__file__).parent
FAST = [1.0, 2.0, 3.0, 4.0]
SLOW = [100.0, 101.0]

MAIN = """
import os, sys
import numpy as np
sys.path.insert(0, {here!r})
from test_worker_hygiene import make_model
from torchshm.storage import evaluate
print(os.getpid(), flush=True)
design = np.array([[v] for v in {values!r}])
evaluate(make_model({tmp!r}), design, store={store!r}, {executor})
"""


def make_model(tmp: str) -> ExternalModel:
    """The stand-in program as an ExternalModel (the same identity in every process)."""
    return ExternalModel([sys.executable, str(HERE / "hygiene_fe.py")], x=[0.0, 0.5, 1.0],
                         loads=[1.0], workdir=Path(tmp) / "runs", names=["E"],
                         identity="hygiene-fe-v1", keep_workdirs=False)


def _alive(pids: list[int]) -> list[int]:
    """The pids that still run (zombies do not run)."""
    alive = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    return alive


def kill_main_mid_run(tmp: Path, executor: str) -> tuple[list[int], float]:
    """Start an evaluation of FAST then SLOW in a child process, kill -9 it once the fast runs
    are stored and both slow programs run; returns its descendants then and the seconds until
    none was left (inf if some still run after 10 s)."""
    store = tmp / "store.sqlite"
    code = textwrap.dedent(MAIN).format(here=str(HERE), values=FAST + SLOW, tmp=str(tmp),
                                        store=str(store), executor=executor)
    env = dict(os.environ, HYGIENE_CALLS=str(tmp / "calls.txt"), HYGIENE_SLOW_S="300",
               OMP_NUM_THREADS="1")
    main = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60.0
    model = make_model(str(tmp))
    while time.monotonic() < deadline and main.poll() is None:
        if len(list(tmp.glob("slow-*.pids"))) == 2 and EvaluationStore(store).count(model) == len(FAST):
            break
        time.sleep(0.1)
    assert main.poll() is None, main.stdout.read().decode()
    family = [p.pid for p in psutil.Process(main.pid).children(recursive=True)]
    fe = [int(pid) for f in tmp.glob("slow-*.pids") for pid in f.read_text().split()]
    assert set(fe) <= set(family) | set(fe) and len(fe) == 4
    main.send_signal(signal.SIGKILL)
    main.wait()
    t0 = time.monotonic()
    everyone = sorted(set(family) | set(fe))
    while _alive(everyone) and time.monotonic() - t0 < 10.0:
        time.sleep(0.1)
    left = _alive(everyone)
    for pid in left:  # leave nothing behind for the next test
        os.kill(pid, signal.SIGKILL)
    return left, (time.monotonic() - t0) if not left else float("inf")


DASK = "executor=__import__('torchshm.storage', fromlist=['dask_client']).dask_client(n_workers=2)"


@pytest.mark.slow
@pytest.mark.parametrize("executor", ["n_jobs=2", DASK], ids=["joblib", "dask"])
def test_kill_main_leaves_no_worker_or_program_and_resume_repeats_no_run(tmp_path: Path, executor: str) -> None:
    """joblib: loky workers and their programs; dask: a LocalCluster's worker processes, their
    programs, and the programs' own children (the worker ends at once, before its watchdog)."""
    left, seconds = kill_main_mid_run(tmp_path, executor)
    assert not left, f"still running 10 s after kill -9: {left}"
    print(f"workers and FE programs gone {seconds:.1f} s after kill -9")

    os.environ["HYGIENE_CALLS"] = str(tmp_path / "calls.txt")
    os.environ["HYGIENE_SLOW_S"] = "0"
    try:
        design = np.array([[v] for v in FAST + SLOW])
        resumed = evaluate(make_model(str(tmp_path)), design, store=tmp_path / "store.sqlite")
    finally:
        del os.environ["HYGIENE_CALLS"], os.environ["HYGIENE_SLOW_S"]
    calls = collections.Counter(float(v) for v in (tmp_path / "calls.txt").read_text().split())
    assert resumed.ok.all() and resumed.n_new == len(SLOW) and resumed.n_reused == len(FAST)
    assert all(calls[v] == 1 for v in FAST) and all(calls[v] == 2 for v in SLOW)
    assert np.allclose(resumed.outputs[:, 0, -1], 2 * design[:, 0])
