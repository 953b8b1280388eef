"""evaluate on any executor with submit (concurrent.futures here), cores_per_run."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import torch
from dask_models import Counted, calls

from torchshm.forward import CoresPerRun
from torchshm.storage import ParallelModel
from torchshm.forward.cores import available_cores, fit_workers, thread_limits
from torchshm.storage import EvaluationStore, evaluate

DESIGN = np.array([[1.0, 0.0], [2.0, 1.0], [1.0, 0.0], [3.0, -1.0]])


def test_a_thread_pool_gives_the_serial_answer_and_fills_the_store(tmp_path: Path) -> None:
    model, store = Counted(str(tmp_path / "calls.txt")), EvaluationStore(tmp_path / "s.sqlite")
    with ThreadPoolExecutor(2) as pool:
        result = evaluate(model, DESIGN, store=store, executor=pool, cores_per_run=1)
        again = evaluate(ParallelModel(model, executor=pool), DESIGN, store=store)
    reference = evaluate(Counted(str(tmp_path / "ref.txt")), DESIGN)
    assert np.array_equal(result.outputs, reference.outputs) and result.ok.all()
    assert (result.n_new, again.n_new, store.count(model)) == (3, 0, 3)
    assert sorted(a for a, *_ in calls(tmp_path / "calls.txt")) == [1.0, 2.0, 3.0]


def test_cores_per_run_reaches_the_run_and_is_restored(tmp_path: Path) -> None:
    before = os.environ.get("OMP_NUM_THREADS")
    evaluate(Counted(str(tmp_path / "calls.txt")), DESIGN[:1], cores_per_run=1, cores_env=["CCX_NPROC"])
    assert [omp for *_, omp in calls(tmp_path / "calls.txt")] == ["1"]
    assert os.environ.get("OMP_NUM_THREADS") == before
    with thread_limits(1, ["CCX_NPROC"]):
        assert os.environ["CCX_NPROC"] == "1" and torch.get_num_threads() == 1
    assert "CCX_NPROC" not in os.environ
    wrapped = CoresPerRun(Counted("unused"), 1)
    assert wrapped.identity == "dask-counted-v1" and wrapped.names == ("a", "b")


def test_runs_that_do_not_fit_the_machine_are_refused_before_any_run(tmp_path: Path) -> None:
    cores = available_cores()
    assert fit_workers(-1, 1, cores=8) == 8 and fit_workers(-1, 3, cores=8) == 2
    assert fit_workers(-2, 2, cores=8) == 3 and fit_workers(2, 4, cores=8) == 2
    with pytest.raises(ValueError, match="3 workers x cores_per_run=4 need 12 cores, but this machine has 8"):
        fit_workers(3, 4, cores=8)
    with pytest.raises(ValueError, match=f"more than the {cores} cores"):
        evaluate(Counted(str(tmp_path / "calls.txt")), DESIGN, cores_per_run=cores + 1)
    with pytest.raises(ValueError, match="workers x cores_per_run"):
        ParallelModel(Counted("unused"), n_jobs=cores + 1, cores_per_run=1)
    with pytest.raises(ValueError, match="cores_per_run must be a positive integer"):
        evaluate(Counted("unused"), DESIGN, cores_per_run=0)
    with pytest.raises(ValueError, match="executor must have submit"):
        evaluate(Counted("unused"), DESIGN, executor=object())
    assert not (tmp_path / "calls.txt").exists()


class _Failing:
    """An executor whose futures fail: a=1 as a worker Dask gave up on, a=2 as a broken pool."""

    def submit(self, fn, task, key):
        from concurrent.futures import Future
        from concurrent.futures.process import BrokenProcessPool

        future: Future = Future()
        a = float(key.split(",")[0])
        if a == 1.0:
            future.set_exception(RuntimeError("KilledWorker: attempted to run task 3 times"))
        elif a == 2.0:
            future.set_exception(BrokenProcessPool("a child process terminated abruptly"))
        else:
            future.set_result(fn(task, key))
        return future


def test_a_task_dask_gave_up_on_is_stored_failed_a_broken_pool_is_not(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    model = Counted(str(tmp_path / "calls.txt"))
    result = evaluate(model, DESIGN, store=store, executor=_Failing())
    assert result.ok.tolist() == [False, False, False, True]
    assert "KilledWorker" in result.errors[0] and "BrokenProcessPool" in result.errors[1]
    assert store.count(model) == 2 and store.count(model, status="failed") == 1
    assert evaluate(model, DESIGN, store=store).n_new == 1  # the broken pool's run, never stored


class _Recomputing:
    """An executor that runs every task twice, as Dask does when the worker holding a finished
    result dies before the result is collected: the first result is lost."""

    def submit(self, fn, task, key):
        from concurrent.futures import Future

        fn(task, key)  # finished on a worker that then died: its result never arrives
        future: Future = Future()
        future.set_result(fn(task, key))
        return future


def test_a_result_lost_with_its_worker_is_taken_from_the_spool_not_run_again(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    model = Counted(str(tmp_path / "calls.txt"))
    result = evaluate(model, DESIGN, store=store, executor=_Recomputing())
    assert sorted(a for a, *_ in calls(tmp_path / "calls.txt")) == [1.0, 2.0, 3.0]  # once each
    reference = evaluate(Counted(str(tmp_path / "ref.txt")), DESIGN)
    assert np.array_equal(result.outputs, reference.outputs) and store.count(model) == 3
    assert not list(store.spool_folder.glob("*.npz"))  # the deposits were ingested
