"""Dask: a LocalCluster of 2 worker processes evaluates and identifies through the store; a
worker killed in a run loses that run only; ``executor=dask`` from the Hydra config."""

from __future__ import annotations

import collections
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import torch
from dask_models import Counted, calls
from hydra import compose, initialize_config_dir

import torchshm
from torchshm import Measurements, Normal, Problem
from torchshm.cli.models import with_executor
from torchshm.config import CONF_DIR, CONFIG_NAME, register_configs, to_settings
from torchshm.storage import ParallelModel
from torchshm.storage import EvaluationStore, dask_client, evaluate
from torchshm.storage.dask_cluster import jobqueue_cluster


@pytest.fixture(scope="module")
def from_config(tmp_path_factory: pytest.TempPathFactory):
    """``executor=dask executor.n_jobs=2`` composed from conf/ and built as the command line
    does: a ParallelModel whose client runs a LocalCluster of 2 worker processes."""
    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(CONFIG_NAME, overrides=["executor=dask", "executor.n_jobs=2"])
    settings = to_settings(cfg)
    model = with_executor(Counted(str(tmp_path_factory.mktemp("dask") / "calls.txt")), settings.executor)
    yield settings, model
    model.close()


@pytest.fixture(scope="module")
def client(from_config):
    return from_config[1].executor


def test_executor_dask_from_the_hydra_config(from_config) -> None:
    settings, model = from_config
    assert (settings.executor.kind, settings.executor.cores_per_run) == ("dask", 1)
    assert isinstance(model, ParallelModel) and model.cores_per_run == 1
    info = model.executor.scheduler_info(n_workers=-1)["workers"].values()
    assert [w["nthreads"] for w in info] == [1, 1]  # processes=True, threads_per_worker=1
    theta = torch.tensor([[1.0, 2.0], [3.0, 4.0]])
    assert torch.allclose(model(theta), Counted("/dev/null")(theta))


@pytest.mark.slow
def test_identification_through_the_store(client, tmp_path: Path) -> None:
    counter = tmp_path / "calls.txt"
    model = ParallelModel(Counted(str(counter)), executor=client, cores_per_run=1)
    rng = np.random.default_rng(0)
    truth = torch.tensor([2.0, 0.5])
    y = Counted(str(tmp_path / "data.txt"))(truth).numpy() + 0.05 * rng.standard_normal((2, 6))
    problem = Problem(model, Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.05),
                      kernel="independent", priors={"a": Normal(0.0, 5.0), "b": Normal(0.0, 5.0),
                                                    "sigma_a": 0.01},
                      sigma_m=0.0, store=tmp_path / "store.sqlite")
    post = torchshm.identify(problem, method="emcee", seed=0, n_walkers=4, n_steps=12)
    runs = calls(counter)
    store = EvaluationStore(tmp_path / "store.sqlite")
    assert store.count(model) == post.n_model_evaluations == len(runs) > 0
    assert len({pid for _, pid, _ in runs}) == 2 and {omp for *_, omp in runs} == {"1"}
    assert len({a for a, *_ in runs}) == len(runs)  # no θp ran twice


def _kill_when_started(path: Path) -> list[int]:
    """SIGKILL the worker whose pid appears in ``path`` (once); returns [pid]."""
    killed: list[int] = []

    def watch() -> None:
        deadline = time.monotonic() + 60.0
        while not path.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        if path.exists():
            time.sleep(0.2)
            killed.append(int(path.read_text()))
            os.kill(killed[0], signal.SIGKILL)
            path.unlink()

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return killed


@pytest.mark.slow
def test_a_killed_worker_loses_only_its_run(client, tmp_path: Path) -> None:
    counter, store = tmp_path / "calls.txt", EvaluationStore(tmp_path / "store.sqlite")
    model = Counted(str(counter), slow=50.0, delay=2.0)
    design = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [50.0, 0.0], [4.0, 0.0], [5.0, 0.0]])
    killed = _kill_when_started(Path(f"{counter}.slow-50.0"))
    result = evaluate(model, design, store=store, executor=client)
    assert len(killed) == 1
    runs = collections.Counter(a for a, *_ in calls(counter))
    assert runs[50.0] == 2 and all(runs[a] == 1 for a in (1.0, 2.0, 3.0, 4.0, 5.0)), runs
    assert result.ok.all() and store.count(model) == len(design)  # re-queued by Dask, redone
    again = evaluate(model, design, store=store, executor=client)
    assert again.n_new == 0 and np.array_equal(again.outputs, result.outputs)


def test_jobqueue_jobs_have_cores_per_run_and_one_thread() -> None:
    cluster = jobqueue_cluster("slurm", cores_per_run=4, memory="8GB", walltime="00:30:00",
                               queue="compute")
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    assert "#SBATCH --cpus-per-task=4" in script and script.rstrip().endswith("--nthreads 1")
    assert "#SBATCH -p compute" in script and "#SBATCH -t 00:30:00" in script
    with pytest.raises(ValueError, match="unknown jobqueue 'pbz'"):
        jobqueue_cluster("pbz")


def test_too_many_cores_are_refused_before_any_run(client) -> None:
    with pytest.raises(ValueError, match="cores_per_run=64"):
        ParallelModel(Counted("unused"), executor=client, cores_per_run=64)
    with pytest.raises(ValueError, match="workers x cores_per_run"):
        dask_client(n_workers=os.cpu_count() + 1, cores_per_run=1)
