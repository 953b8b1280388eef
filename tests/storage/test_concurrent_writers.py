"""Two processes writing to one store at the same time lose nothing."""

from __future__ import annotations

import collections
import os
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import numpy as np
from storage_models import GridModel, grid, read_counter

from torchshm.storage import EvaluationStore, evaluate, theta_key

HERE = Path(__file__).parent
N_E, N_K = 9, 5  # 45 grid points


def _run_together(store: Path, counter: Path, delay: float, ranges: list[tuple[int, int]]):
    go = store.parent / "go"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    processes = [
        subprocess.Popen(
            [sys.executable, str(HERE / "grid_run.py"), str(store), str(counter), str(delay),
             str(N_E), str(N_K), str(first), str(stop), str(go)],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        )
        for first, stop in ranges
    ]
    try:
        deadline = time.monotonic() + 300.0  # starting Python with torch on a loaded machine
        while len(list(store.parent.glob("go.ready.*"))) < len(ranges):
            assert time.monotonic() < deadline and all(p.poll() is None for p in processes)
            time.sleep(0.01)
        go.touch()
        outputs = [p.communicate(timeout=300)[0].decode() for p in processes]
    finally:
        for p in processes:  # never leave a writer waiting for its start signal
            if p.poll() is None:
                p.kill()
                p.wait()
    assert [p.returncode for p in processes] == [0] * len(ranges), outputs


def _overlap(records: list, pids: list[int]) -> bool:
    spans = []
    for pid in pids:
        times = [datetime.fromisoformat(r.finished_at) for r in records if r.pid == pid]
        spans.append((min(times), max(times)))
    return spans[0][0] < spans[1][1] and spans[1][0] < spans[0][1]


def test_two_processes_overlapping_and_distinct_theta(tmp_path: Path) -> None:
    store, counter = EvaluationStore(tmp_path / "store.sqlite"), tmp_path / "calls.txt"
    _run_together(store.path, counter, 0.02, [(0, 30), (15, 45)])

    model, theta = GridModel(), grid(N_E, N_K)
    records = store.records(model)
    assert len(records) == 45 and all(r.ok for r in records)
    pids = sorted({r.pid for r in records})
    assert len(pids) == 2 and _overlap(records, pids)  # the two writers really overlapped
    ends = [(key, pid) for what, key, pid in read_counter(str(counter)) if what == "end"]
    calls = collections.Counter(key for key, _ in ends)
    assert len(calls) == 45 and len(ends) == 45  # rows 15..29 are wanted by both, run by one
    print(f"model runs: {len(ends)} ({collections.Counter(pid for _, pid in ends)} per process), "
          f"run twice: {sum(n > 1 for n in calls.values())}, stored: {len(records)}")
    reference = evaluate(model, theta)
    stored = {r.key: r.outputs for r in records}
    for row, expected in zip(theta, reference.outputs):
        assert np.array_equal(stored[theta_key(row)], expected)



class _OtherStudy(GridModel):
    """While running θp (20, 1), another study on the same store finishes θp (30, 2)."""

    def __init__(self, store: EvaluationStore, counter: str) -> None:
        super().__init__(counter=counter)
        self.store = store

    def __call__(self, theta_p):
        if float(theta_p[0]) == 20.0:
            evaluate(GridModel(counter=self.counter), [[30.0, 2.0]], store=self.store)
        return super().__call__(theta_p)


def test_a_run_finished_by_another_process_meanwhile_is_not_repeated(tmp_path: Path) -> None:
    store, counter = EvaluationStore(tmp_path / "s.sqlite"), str(tmp_path / "calls.txt")
    result = evaluate(_OtherStudy(store, counter), [[20.0, 1.0], [30.0, 2.0]], store=store)
    starts = [key for what, key, _ in read_counter(counter) if what == "start"]
    assert sorted(starts) == ["20,1", "30,2"]  # (30, 2) ran once, in the other study
    assert result.n_new == 1 and result.n_reused == 1 and result.ok.all()
