"""A user's own model, priors and data from a config folder outside the repository."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

import torchshm
from tests.cli.test_bad_input import assert_one_line_error

#: the user's model: strain = a * bending shape + b * a second shape, all load cases at once
MODEL = '''
import torch

class TwoShapes:
    names = ("a", "b")

    def __init__(self, length=10.0, n=51, loads=(2.0, 5.0, 8.0), shift=0.0):
        self.x = torch.linspace(0.0, length, n, dtype=torch.float64) + shift
        self.loads = torch.tensor(loads, dtype=torch.float64)

    def __call__(self, theta_p):
        t = torch.as_tensor(theta_p, dtype=torch.float64)
        d = (self.x[None, :] - self.loads[:, None]).abs()
        first, second = torch.exp(-d / 2.0), torch.cos(self.x / 3.0)[None, :].expand_as(d)
        return t[..., 0, None, None] * first + t[..., 1, None, None] * second
'''
PRIORS = '''
a: {dist: uniform, a: 0.0, b: 100.0, plausible: [10.0, 60.0], label: "$a$", unit: µε}
b: {dist: normal, mean: 0.0, sd: 10.0, bounds: [-50.0, 50.0], plausible: [-10.0, 10.0]}
sigma_a: {dist: gamma, alpha: 2.0, beta: 2.0, bounds: [0.0, 5.0], plausible: [0.2, 2.0]}
length: {dist: gamma, alpha: 3.0, beta: 1.0, bounds: [0.0, 10.0], plausible: [0.2, 5.0]}
'''
TRUTH = (40.0, 5.0)


@pytest.fixture
def user(tmp_path: Path) -> Path:
    """``tmp_path`` (the working directory) holds my_model.py, my_conf/ and campaign.csv."""
    (tmp_path / "my_model.py").write_text(MODEL)
    (tmp_path / "my_conf" / "model").mkdir(parents=True)
    (tmp_path / "my_conf" / "priors").mkdir()
    (tmp_path / "my_conf" / "model" / "mine.yaml").write_text("_target_: my_model.TwoShapes\nn: 51\n")
    (tmp_path / "my_conf" / "priors" / "mine.yaml").write_text(PRIORS)
    x = np.linspace(0.0, 10.0, 51)
    loads = np.array([2.0, 5.0, 8.0])
    d = np.abs(x[None, :] - loads[:, None])
    y = TRUTH[0] * np.exp(-d / 2.0) + TRUTH[1] * np.cos(x / 3.0)[None, :]
    y = y + 0.2 * np.random.default_rng(0).standard_normal(y.shape)
    torchshm.Measurements(x, y, loads, sigma_e=0.2, attrs={"truth_a": TRUTH[0]}).save(tmp_path / "campaign.csv")
    return tmp_path


BASE = ["--config-dir", "my_conf", "model=mine", "priors=mine", "data.path=campaign.csv",
        "data.loads=[2.0,8.0]", "predict.loads=[5.0]", "predict.n=200", "data.resolution=null"]


def test_priors_naming_a_parameter_the_model_does_not_take(cli, user: Path) -> None:
    (user / "my_conf" / "priors" / "mine.yaml").write_text(PRIORS.replace("\nb:", "\nc:"))
    assert_one_line_error(cli(*BASE), "unknown parameter", "'c'")
    assert not (user / "runs").exists() or not any((user / "runs").rglob("run.json"))


def test_target_that_does_not_import(cli, user: Path) -> None:
    assert_one_line_error(cli(*BASE, "model._target_=my_model.NoSuchModel"), "model:", "NoSuchModel")
    assert_one_line_error(cli(*BASE, "model._target_=not_a_module.Model"), "model:", "not_a_module")


def test_model_whose_positions_miss_the_data(cli, user: Path) -> None:
    assert_one_line_error(cli(*BASE, "+model.shift=0.013"), "position")


def test_model_whose_load_cases_miss_the_data(cli, user: Path) -> None:
    assert_one_line_error(cli(*BASE, "+model.loads=[2.0,5.0]", "data.loads=[8.0]", "predict.loads=[]"), "load case")


@pytest.mark.slow
@pytest.mark.parametrize("method", [
    ["method=vbmc", "method.max_fun_evals=20", "method.n_samples=2000"],
    ["method=emcee", "method.n_walkers=10", "method.n_steps=60", "method.burn=30",
     "method.log_every=20", "method.window=200", "executor=joblib", "executor.n_jobs=2"],
])
def test_user_model_identifies(cli, user: Path, method: list[str]) -> None:
    result = cli(*BASE, *method, "hydra.run.dir=run")
    assert result.returncode == 0, result.stderr
    run = user / "run"
    for name in ("posterior.nc", "summary.csv", "corner.png", "trace.png", "predictive.csv",
                 "predictive.png", "run.json"):
        assert (run / name).is_file(), name
    assert any((run / "tb").iterdir())
    post = torchshm.load_posterior(run / "posterior.nc")
    assert post.names == ["a", "b", "sigma_a", "length"]
    record = json.loads((run / "run.json").read_text())
    assert record["settings"]["model"]["_target_"] == "my_model.TwoShapes"
    mean = post.summary().as_dict()
    assert abs(mean["a"]["mean"] - TRUTH[0]) < 3.0, mean["a"]  # sd of a is ~0.1 µε here
