"""A grid evaluation killed with SIGKILL part-way resumes without repeating finished runs."""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from storage_models import GridModel, grid, read_counter

from torchshm.storage import EvaluationStore, evaluate, theta_key

HERE = Path(__file__).parent
N_E, N_K, DELAY = 5, 4, 0.15  # 20 grid points, 0.15 s per model call


def _start_grid(store: Path, counter: Path) -> subprocess.Popen:
    command = [sys.executable, str(HERE / "grid_run.py"), str(store), str(counter), str(DELAY),
               str(N_E), str(N_K), "0", str(N_E * N_K)]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)


def test_sigkill_then_rerun_repeats_no_finished_evaluation(tmp_path: Path) -> None:
    store, counter = EvaluationStore(tmp_path / "store.sqlite"), tmp_path / "calls.txt"
    model, theta = GridModel(delay=DELAY, counter=str(counter)), grid(N_E, N_K)
    process = _start_grid(store.path, counter)
    deadline = time.monotonic() + 60.0
    while store.count(model) < 6 and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert process.returncode == -signal.SIGKILL, process.stdout.read().decode()
    finished_before = {theta_key(row) for row in store.all(model)[0]}
    calls_before = [line for line in read_counter(str(counter)) if line[0] == "start"]
    assert 6 <= len(finished_before) < len(theta)

    rerun = evaluate(model, theta, store=store)

    calls = collections.Counter(k for what, k, _ in read_counter(str(counter)) if what == "start")
    canonical = {theta_key(row): ",".join(f"{v:.12g}" for v in row) for row in theta}
    for key in finished_before:  # every evaluation stored before the kill ran exactly once
        assert calls[canonical[key]] == 1
    repeated = [k for k, n in calls.items() if n > 1]
    assert len(repeated) <= 1  # at most the run in flight at the kill, which never finished
    assert set(calls) == set(canonical.values())
    assert rerun.n_new == len(theta) - len(finished_before)
    assert rerun.n_reused == len(finished_before)
    assert rerun.ok.all() and store.count(model) == len(theta)

    reference = evaluate(GridModel(), theta, store=tmp_path / "reference.sqlite")
    assert np.array_equal(rerun.outputs, reference.outputs)
    stored_theta, stored_outputs = store.all(model)
    order = [list(map(theta_key, stored_theta)).index(theta_key(row)) for row in theta]
    assert np.array_equal(stored_outputs[order], reference.outputs)
    print(f"calls before kill: {len(calls_before)}, stored before kill: {len(finished_before)}, "
          f"calls in rerun: {rerun.n_new}, total calls: {sum(calls.values())}, "
          f"repeated: {len(repeated)}")
