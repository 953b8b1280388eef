"""SIGTERM (Slurm) and Ctrl-C stop an evaluation at once, keep every finished run, and print one
line on how to resume; the rerun on the same store repeats no stored run."""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from storage_models import GridModel, grid, read_counter

from torchshm.storage import EvaluationStore, evaluate, theta_key
from torchshm.storage.interrupt import EXIT_SIGTERM, resumable

HERE = Path(__file__).parent
DELAY = 0.15


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt(tmp_path: Path, signum: int) -> tuple[subprocess.CompletedProcess, EvaluationStore, Path]:
    store, counter = EvaluationStore(tmp_path / "store.sqlite"), tmp_path / "calls.txt"
    command = [sys.executable, str(HERE / "grid_run.py"), str(store.path), str(counter),
               str(DELAY), "5", "4", "0", "20"]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    # a shell's background job inherits SIGINT ignored (and Python then installs no Ctrl-C
    # handler): give the child the default disposition, as an interactive terminal would
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               preexec_fn=_default_sigint)
    deadline = time.monotonic() + 120.0
    while store.count() < 4 and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    starts = sum(what == "start" for what, _, _ in read_counter(str(counter)))
    process.send_signal(signum)
    out, err = process.communicate(timeout=300)
    # stops at once: no model call starts after the signal (one may race with it)
    assert sum(what == "start" for what, _, _ in read_counter(str(counter))) <= starts + 1
    return subprocess.CompletedProcess(command, process.returncode, out.decode(), err.decode()), store, counter


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_signal_stops_keeps_finished_runs_and_says_how_to_resume(tmp_path: Path, signum: int) -> None:
    done, store, counter = _interrupt(tmp_path, signum)
    lines = [line for line in done.stderr.splitlines() if "stopped by" in line]
    assert len(lines) == 1, done.stderr
    name = signal.Signals(signum).name
    assert f"stopped by {name}" in lines[0] and str(store.path) in lines[0] and "resume" in lines[0]
    if signum == signal.SIGTERM:
        assert done.returncode == EXIT_SIGTERM and "Traceback" not in done.stderr
    else:  # Ctrl-C propagates as KeyboardInterrupt, as Python does
        assert done.returncode in (-signal.SIGINT, 1, 130)
    model = GridModel(delay=DELAY, counter=str(counter))
    kept = {theta_key(row) for row in store.all(model)[0]}
    finished = {key for what, key, _ in read_counter(str(counter)) if what == "end"}
    assert 4 <= len(kept) < 20 and store.check().ok
    assert len(finished) - len(kept) <= 1  # at most the run whose commit was cut short

    rerun = evaluate(model, grid(5, 4), store=store)
    starts = collections.Counter(k for what, k, _ in read_counter(str(counter)) if what == "start")
    canonical = {theta_key(row): ",".join(f"{v:.12g}" for v in row) for row in grid(5, 4)}
    assert all(starts[canonical[key]] == 1 for key in kept)  # no stored run repeated
    assert rerun.ok.all() and rerun.n_reused == len(kept) and rerun.n_new == 20 - len(kept)


def test_resumable_turns_sigterm_into_exit_143_and_restores_the_handler(
    capsys: pytest.CaptureFixture[str],
) -> None:
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(SystemExit) as stop:
        with resumable("study", "/data/store.sqlite"):
            with resumable("inner", "/data/store.sqlite"):  # nested: only the outer prints
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)
    assert stop.value.code == EXIT_SIGTERM and signal.getsignal(signal.SIGTERM) is before
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["study stopped by SIGTERM; every finished model run is kept in "
                   "/data/store.sqlite; to resume, call it again with the same store"]


def test_without_store_the_line_says_nothing_is_kept(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(KeyboardInterrupt):
        with resumable("fit", None):
            raise KeyboardInterrupt
    assert "no evaluation store was given" in capsys.readouterr().err
