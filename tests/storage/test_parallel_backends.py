"""joblib processes and submitit jobs give the same results as evaluating in process."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import submitit
from storage_models import GridModel, grid, read_counter

from torchshm.storage import EvaluationStore, evaluate, evaluation_options, make_executor

HERE = Path(__file__).parent


def test_joblib_two_processes_equal_serial(tmp_path: Path) -> None:
    theta = grid(4, 3)
    counter = str(tmp_path / "calls.txt")
    serial = evaluate(GridModel(), theta, store=tmp_path / "serial.sqlite")
    store = EvaluationStore(tmp_path / "joblib.sqlite")
    parallel = evaluate(GridModel(delay=0.05, counter=counter), theta, store=store, n_jobs=2)
    assert np.array_equal(parallel.outputs, serial.outputs)
    assert parallel.n_new == 12 and parallel.ok.all()
    calls = read_counter(counter)
    assert len({pid for _, _, pid in calls}) == 2  # two worker processes did the runs
    assert sorted(key for what, key, _ in calls if what == "start") == sorted(
        f"{e:.12g},{k:.12g}" for e, k in theta
    )
    assert store.count(GridModel()) == 12
    again = evaluate(GridModel(counter=counter), theta, store=store, n_jobs=2)
    assert again.n_new == 0 and len(read_counter(counter)) == len(calls)


def test_a_parallel_model_through_a_store_keeps_its_workers(tmp_path: Path) -> None:
    from torchshm.storage import ParallelModel

    theta, counter = grid(3, 2), str(tmp_path / "calls.txt")
    store = EvaluationStore(tmp_path / "s.sqlite")
    result = evaluate(ParallelModel(GridModel(delay=0.05, counter=counter), n_jobs=2), theta, store=store)
    assert result.n_new == 6 and result.ok.all()
    assert np.array_equal(result.outputs, evaluate(GridModel(), theta).outputs)
    assert len({pid for _, _, pid in read_counter(counter)} - {os.getpid()}) == 2  # both workers ran
    assert {r.pid for r in store.records(GridModel())} != {os.getpid()}  # stored by the workers


def test_submitit_debug_executor_writes_through_spool(tmp_path: Path) -> None:
    theta = grid(3, 2)
    store = EvaluationStore(tmp_path / "s.sqlite")
    executor = make_executor("debug", tmp_path / "jobs")
    result = evaluate(GridModel(), theta, store=store, executor=executor)
    assert np.array_equal(result.outputs, evaluate(GridModel(), theta).outputs)
    assert store.count(GridModel()) == 6
    assert not list(store.spool_folder.glob("*.npz"))  # everything ingested


def test_submitit_local_executor(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # job processes must import the model's module, as on a cluster
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))
    theta = np.array([[20.0, 1.0], [30.0, 2.0]])
    store, counter = EvaluationStore(tmp_path / "s.sqlite"), str(tmp_path / "calls.txt")
    options = evaluation_options("local", tmp_path / "jobs", params={"timeout_min": 2})
    result = evaluate(GridModel(counter=counter), theta, store=store, **options)
    assert result.ok.all() and result.n_new == 2
    assert np.array_equal(result.outputs, evaluate(GridModel(), theta).outputs)
    assert os.getpid() not in {pid for _, _, pid in read_counter(counter)}  # ran in the jobs
    assert store.count(GridModel(), status="ok") == 2


class _DeadJob:
    """A submitit job whose process died before writing a result (e.g. out of memory)."""

    job_id = "4242_1"

    def result(self) -> None:
        raise submitit.core.utils.UncompletedJobError(
            "Job 4242_1 (task: 0) with path /jobs/4242_1_result.pkl\n"
            "has not produced any output (state: OUT_OF_MEMORY)\nError stream produced:\n..."
        )


class _HalfDeadExecutor:
    """Runs the first key with submitit's debug executor; the job of the second one dies."""

    def __init__(self, folder: Path) -> None:
        self.debug = make_executor("debug", folder)

    def map_array(self, task, keys):
        return [*self.debug.map_array(task, keys[:1]), _DeadJob()]


def test_a_dying_job_is_recorded_as_failed(tmp_path: Path) -> None:
    theta = np.array([[20.0, 1.0], [30.0, 2.0]])
    store = EvaluationStore(tmp_path / "s.sqlite")
    result = evaluate(GridModel(), theta, store=store, executor=_HalfDeadExecutor(tmp_path))
    assert result.ok.tolist() == [True, False]
    assert result.errors[1] == (
        "job 4242_1 failed: UncompletedJobError: Job 4242_1 (task: 0) with path "
        "/jobs/4242_1_result.pkl has not produced any output (state: OUT_OF_MEMORY)"
    )
    assert store.failures(GridModel())[1] == [result.errors[1]]
    retried = evaluate(GridModel(), theta, store=store, retry_failed=True)
    assert retried.ok.all() and retried.n_new == 1


def test_a_worker_that_dies_is_a_failed_evaluation_not_a_crash(tmp_path: Path) -> None:
    theta = grid(3, 2)
    crash = (round(float(theta[2, 0]), 9), round(float(theta[2, 1]), 9))
    store = EvaluationStore(tmp_path / "s.sqlite")
    res = evaluate(GridModel(fail={crash: "exit"}), theta, store=store, n_jobs=2)
    assert res.ok.sum() == len(theta) - 1 and not res.ok[2]
    assert "worker process died" in res.errors[2]
    assert store.count(GridModel()) == len(theta)  # the failure is recorded too
    again = evaluate(GridModel(), theta, store=store, n_jobs=2)
    assert again.n_new == 0  # not retried unless asked
