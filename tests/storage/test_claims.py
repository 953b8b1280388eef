"""Claims: a θp being run by one process is not run again by another."""

from __future__ import annotations

import socket
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from storage_models import GridModel, read_counter

from torchshm.storage import EvaluationStore, evaluate, theta_key
from torchshm.storage import claims
from torchshm.storage.record import run_model

HOLD = """
import sys, time
from torchshm.storage import EvaluationStore, claims
store = EvaluationStore(sys.argv[1])
print(claims.claim(store, "m", "1,2", True), flush=True)
time.sleep(float(sys.argv[2]))
"""


def _insert(store: EvaluationStore, host: str, pid: int, started: str, at: float) -> None:
    with sqlite3.connect(store.path) as con:
        con.execute("INSERT OR REPLACE INTO claims VALUES ('m', '1,2', ?, ?, ?, ?)", (host, pid, started, at))


def test_claim_release_and_done(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    assert claims.claim(store, "m", "1,2", True) == "mine"
    assert claims.claim(store, "m", "1,2", True) == "mine"  # our own claim again
    assert [row[:2] for row in claims.held(store)] == [("m", "1,2")]
    claims.release(store, "m", "1,2")
    assert claims.held(store) == []
    record = run_model(GridModel(), "m", "1,2", np.array([1.0, 2.0]), (3, 7))
    store.put(record)
    assert claims.claim(store, "m", "1,2", True) == "done"


def test_a_live_claim_of_another_process_is_held(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(store.path), "30"], stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline().strip() == "mine"
        assert claims.claim(store, "m", "1,2", True) == "held"
    finally:
        holder.kill()
        holder.wait()
    assert claims.claim(store, "m", "1,2", True) == "mine"  # its process is gone: taken over


def test_dead_and_stale_claims_are_taken_over(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    gone = subprocess.Popen(["true"])
    gone.wait()
    _insert(store, socket.gethostname(), gone.pid, "", time.time())
    assert claims.claim(store, "m", "1,2", True) == "mine"
    _insert(store, "another-host", 1, "1", time.time())
    assert claims.claim(store, "m", "1,2", True) == "held"  # other host, fresh: live
    _insert(store, "another-host", 1, "1", time.time() - claims.STALE_AFTER_S - 1.0)
    assert claims.claim(store, "m", "1,2", True) == "mine"


def test_a_failed_run_is_done_unless_failures_are_retried(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    result = evaluate(GridModel(fail={(1.0, 2.0): "raise"}), [[1.0, 2.0]], store=store)
    assert not result.ok[0]
    key = theta_key([1.0, 2.0])
    assert claims.claim(store, result.model, key, accept_failed=True) == "done"
    assert claims.claim(store, result.model, key, accept_failed=False) == "mine"


WAIT = """
import sys
sys.path.insert(0, sys.argv[3])
from storage_models import GridModel
from torchshm.storage import evaluate
print(evaluate(GridModel(delay=float(sys.argv[2]), counter=sys.argv[4]), [[5.0, 1.0]], store=sys.argv[1]).n_new)
"""


def test_a_second_process_waits_for_the_run_in_flight(tmp_path: Path) -> None:
    store, counter = tmp_path / "s.sqlite", str(tmp_path / "calls.txt")
    here = str(Path(__file__).parent)
    first = subprocess.Popen([sys.executable, "-c", WAIT, str(store), "3.0", here, counter],
                             stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60.0
    while not (Path(counter).exists() and read_counter(counter)):
        assert time.monotonic() < deadline and first.poll() is None
        time.sleep(0.02)
    second = subprocess.run([sys.executable, "-c", WAIT, str(store), "0.0", here, counter],
                            capture_output=True, text=True, timeout=120)
    assert first.wait(timeout=120) == 0 and second.returncode == 0, second.stderr
    assert first.stdout.read().strip() == "1" and second.stdout.strip() == "0"
    starts = [key for what, key, _ in read_counter(counter) if what == "start"]
    assert starts == ["5,1"]  # one model run for two processes
