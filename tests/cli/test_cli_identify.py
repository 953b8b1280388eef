"""End-to-end runs of ``torchshm-identify`` with tiny budgets (slow: tens of seconds each),
among them conf/README.md's sweep with Hydra's joblib launcher as written (its block marked
``run-by`` this file, read by the docs test's collector; the emcee budget below appended where
the command leaves it)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

import torchshm
from tests.docs_blocks import commands, run_by

pytestmark = pytest.mark.slow

VBMC_ARGS = ["method=vbmc", "method.max_fun_evals=20", "method.n_samples=2000", "resolution=4",
             "predict.loads=[70.4]", "predict.n=100", "store=evals.sqlite"]
EMCEE_ARGS = ["method=emcee", "method.n_walkers=8", "method.n_steps=40", "method.burn=20",
              "method.log_every=10", "method.window=80", "resolution=4", "predict.loads=[]"]


def sweep_commands() -> list[list[str]]:
    """The ``torchshm-identify`` commands of conf/README.md's sweep blocks, without the program."""
    blocks = run_by(__file__)
    assert [b.path for b in blocks] == ["conf/README.md"], blocks
    lines = [line for block in blocks for line in commands(block)]
    assert all(line[0] == "torchshm-identify" and line[1] == "-m" for line in lines) and len(lines) == 1
    return [line[1:] for line in lines]


def with_budget(args: list[str], budget: list[str]) -> list[str]:
    """``args`` and the overrides of ``budget`` whose key the command does not set itself."""
    given = {a.split("=", 1)[0].lstrip("+~") for a in args if "=" in a}
    return [*args, *(o for o in budget if o.split("=", 1)[0] not in given)]


def only_child(folder: Path) -> Path:
    children = [p for p in folder.iterdir() if p.is_dir()]
    assert len(children) == 1, children
    return children[0]


def test_vbmc_run_writes_every_output(cli, tmp_path: Path) -> None:
    result = cli(*VBMC_ARGS)
    assert result.returncode == 0, result.stderr
    run = only_child(only_child(tmp_path / "runs"))  # runs/<date>/<time>_<overrides>
    assert run.name.endswith("_method.max_fun_evals=20,method.n_samples=2000,method=vbmc,predict.loads=[70.4],"
                             "predict.n=100,resolution=4,store=evals.sqlite")
    for name in ("posterior.nc", "summary.csv", "corner.png", "elbo.png", "trace.png",
                 "predictive.csv", "predictive.png", "run.json", "identify.log"):
        assert (run / name).is_file(), name
    assert (tmp_path / "evals.sqlite").is_file()  # relative to where the command ran

    post = torchshm.load_posterior(run / "posterior.nc")
    assert post.method == "vbmc" and post.names == ["E_c", "log10_K_r", "sigma_a", "length"]
    with open(run / "summary.csv") as f:  # warnings first, as '#' lines
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    assert [r["name"] for r in rows] == post.names
    assert all(float(r["q2.5"]) < float(r["mean"]) < float(r["q97.5"]) for r in rows)
    assert "E_c" in result.stdout and "log10_K_r" in result.stdout  # the summary is printed

    record = json.loads((run / "run.json").read_text())
    # 20 evaluations cannot converge: the result says so wherever a user looks
    assert record["warnings"][0].startswith("NOT CONVERGED: VBMC stopped") and post.warnings == record["warnings"]
    assert (run / "summary.csv").read_text().startswith("# NOT CONVERGED: ")
    printed = result.stdout.splitlines()
    head = next(i for i, line in enumerate(printed) if line.startswith("Posterior (vbmc"))
    assert printed[head - len(post.warnings)].startswith("NOT CONVERGED: ")  # printed first
    assert record["n_model_evaluations"] > 0 and record["log_evidence"] is not None
    assert record["settings"]["data"]["resolution"] == 4.0
    assert [p["load"] for p in record["predictive"]] == [70.4]
    assert 0.0 <= record["predictive"][0]["coverage"] <= 1.0

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(run / "tb"))
    events.Reload()
    assert "elbo" in events.Tags()["scalars"] and "E_c/mean" in events.Tags()["scalars"]


def test_emcee_sweep_with_joblib_launcher(cli, tmp_path: Path) -> None:
    args = sweep_commands()[0]  # conf/README.md: two kernels in two processes
    assert "hydra/launcher=joblib" in args and "kernel=matern32,matern52" in args
    result = cli(*with_budget(args, EMCEE_ARGS))
    assert result.returncode == 0, result.stderr
    sweep = only_child(only_child(tmp_path / "runs" / "multirun"))  # multirun/<date>/<time>
    jobs = sorted(p for p in sweep.iterdir() if p.is_dir())
    assert len(jobs) == 2
    assert "kernel=matern32" in jobs[0].name and "kernel=matern52" in jobs[1].name
    for job in jobs:
        post = torchshm.load_posterior(job / "posterior.nc")
        assert post.method == "emcee"
        assert "length" in post.names
        for name in ("summary.csv", "corner.png", "trace.png", "run.json"):
            assert (job / name).is_file(), (job, name)
        assert not (job / "elbo.png").exists() and not (job / "predictive.csv").exists()

