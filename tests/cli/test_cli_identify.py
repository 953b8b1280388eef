"""End-to-end runs of ``torchshm-identify`` with tiny budgets (slow: tens of seconds each)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

import torchshm

pytestmark = pytest.mark.slow

VBMC_ARGS = ["method=vbmc", "method.max_fun_evals=20", "method.n_samples=2000", "resolution=4",
             "predict.loads=[70.4]", "predict.n=100", "store=evals.sqlite"]
EMCEE_ARGS = ["method=emcee", "method.n_walkers=8", "method.n_steps=40", "method.burn=20",
              "method.log_every=10", "method.window=80", "resolution=4", "predict.loads=[]"]


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
    torchshm.synthetic_campaign(seed=0).save(tmp_path / "campaign.csv")
    result = cli("-m", "kernel=independent,matern32", *EMCEE_ARGS, "data.path=campaign.csv",
                 "hydra/launcher=joblib", "hydra.launcher.n_jobs=2")
    assert result.returncode == 0, result.stderr
    sweep = only_child(only_child(tmp_path / "runs" / "multirun"))  # multirun/<date>/<time>
    jobs = sorted(p for p in sweep.iterdir() if p.is_dir())
    assert len(jobs) == 2
    assert "kernel=independent" in jobs[0].name and "kernel=matern32" in jobs[1].name
    for job, kernel in zip(jobs, ["independent", "matern32"]):
        post = torchshm.load_posterior(job / "posterior.nc")
        assert post.method == "emcee"
        assert ("length" in post.names) == (kernel == "matern32")
        for name in ("summary.csv", "corner.png", "trace.png", "run.json"):
            assert (job / name).is_file(), (job, name)
        assert not (job / "elbo.png").exists() and not (job / "predictive.csv").exists()
