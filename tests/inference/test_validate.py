"""Every refusal of ``identify`` comes before the first model run (one run where the output's
shape or dtype is the cause), in one line naming the input; a parallel run without a store gets
one in its folder and runs."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
import torch

import torchshm
from torchshm import Measurements, Problem
from torchshm.inference.start import StartSettings
from torchshm.inference.validate import method_options, runner, validate
from tests.inference.inference_models import LinearModel


class Counting(LinearModel):
    """A :class:`LinearModel` that counts the parameter vectors it is called with; ``bad``
    makes it return a wrong shape ("shape") or complex numbers ("dtype")."""

    def __init__(self, bad: str = "") -> None:
        super().__init__()
        self.calls, self.bad = 0, bad

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        out = super().__call__(theta_p)
        self.calls += int(np.prod(out.shape[:-2]))
        if self.bad == "shape":
            return out[..., :-1]
        return out.to(torch.complex128) if self.bad == "dtype" else out


def problem_of(model: Counting, **kw: object) -> Problem:
    y = LinearModel()(torch.tensor([1.0, 2.0])).numpy()
    m = Measurements(x=model.x.numpy(), y=y, loads=model.loads.numpy(), sigma_e=0.1)
    priors = {"p0": torchshm.Uniform(0, 3), "p1": torchshm.Uniform(0, 4),
              "sigma_a": torchshm.Uniform(0, 1)}
    return Problem(model, m, kernel="independent", priors=priors, **kw)  # type: ignore[arg-type]


class Executor:  # not a submitit executor: no submit()
    pass


#: (method, options, fragment of the one-line message): every refusal of an option
OPTION_REFUSALS = [
    ("nuts", {}, "unknown method 'nuts'"),
    ("emcee", {"max_fun_evals": 50}, "method='emcee' has no option 'max_fun_evals'"),
    ("vbmc", {"max_fun_eval": 50}, "did you mean 'max_fun_evals'?"),
    ("vbmc", {"max_fun_evals": 5}, "max_fun_evals (method.max_fun_evals) must be at least 20"),
    ("vbmc", {"max_fun_evals": 30.5}, "max_fun_evals (method.max_fun_evals) must be an integer"),
    ("vbmc", {"display": "verbose"}, "display (method.display) must be one of"),
    ("vbmc", {"n_samples": 0}, "n_samples (method.n_samples) must be an integer >= 1"),
    ("vbmc", {"start": {"n_design": 4}}, "start must be a torchshm.inference.start.StartSettings"),
    ("vbmc", {"start": StartSettings(points=np.zeros((2, 2)))}, "start.points must be `N x 3`"),
    ("emcee", {"n_walkers": 4}, "n_walkers (method.n_walkers) must be at least twice"),
    ("emcee", {"n_steps": 0}, "n_steps (method.n_steps) must be an integer >= 1"),
    ("emcee", {"n_steps": 100, "burn": 100}, "burn (method.burn) must be in [0, n_steps)"),
    ("emcee", {"thin": 0}, "thin (method.thin) must be an integer >= 1"),
    ("emcee", {"log_every": 0}, "log_every (method.log_every) must be an integer >= 1"),
    ("emulator", {"batch_size": 0}, "batch_size (method.batch_size) must be an integer >= 1"),
    ("emulator", {"max_model_evaluations": -1}, "max_model_evaluations (method.max_model_evaluations)"),
    ("emulator", {"n_initial": 2.5}, "n_initial (method.n_initial) must be an integer >= 1"),
    ("emulator", {"n_walkers": 5}, "n_walkers (method.n_walkers) must be at least twice"),
    ("emulator", {"tv_tol": 0.0}, "tv_tol (method.tv_tol) must be a finite number > 0"),
    ("emulator", {"sd_tol": float("nan")}, "sd_tol (method.sd_tol) must be a finite number > 0"),
    ("emulator", {"patience": 0}, "patience (method.patience) must be an integer >= 1"),
    ("emulator", {"emulator_kernel": "matern32"}, "emulator_kernel (method.emulator_kernel) must be one of"),
    ("emulator", {"n_jobs": 0}, "n_jobs (method.n_jobs) must be a non-zero integer"),
    ("emulator", {"executor": Executor()}, "executor must be a submitit executor"),
    ("emcee", {"window": 0}, "window (method.window) must be an integer >= 1"),
    ("emulator", {"final_steps": 0}, "final_steps (method.final_steps) must be an integer >= 1"),
    ("emulator", {"n_evidence": -5}, "n_evidence (method.n_evidence) must be an integer >= 1"),
    ("emulator", {"n_steps": 0}, "n_steps (method.n_steps) must be an integer >= 1"),
    ("emulator", {"error_draws": 0}, "error_draws (method.error_draws) must be an integer >= 1"),
    ("vbmc", {"max_iter": 0}, "max_iter (method.max_iter) must be an integer >= 1"),
    ("vbmc", {"fun_eval_start": 1.5}, "fun_eval_start (method.fun_eval_start) must be an integer >= 1"),
]


@pytest.mark.parametrize(("method", "options", "fragment"), OPTION_REFUSALS,
                         ids=[f"{m}-{'-'.join(o) or 'name'}" for m, o, _ in OPTION_REFUSALS])
def test_option_refused_before_any_model_run(method: str, options: dict, fragment: str) -> None:
    model = Counting()
    with pytest.raises(ValueError) as info:
        torchshm.identify(problem_of(model), method, **options)
    assert fragment in str(info.value) and "\n" not in str(info.value)
    assert model.calls == 0


def _bounds(hard: list[float], plausible: list[float]):
    def patched(problem: Problem, which: str) -> np.ndarray:
        bounds = np.array(problem.prior.hard_bounds if which == "hard" else problem.prior.plausible_bounds)
        bounds[0] = hard if which == "hard" else plausible
        return bounds
    return patched


@pytest.mark.parametrize(("hard", "plausible", "fragment"), [
    ([3.0, 0.0], [1.0, 2.0], "hard bounds of 'p0' are [3.0, 0.0]"),
    ([0.0, 3.0], [1.0, np.inf], "plausible box of 'p0' is [1.0, inf], not a finite interval"),
    ([0.0, 3.0], [-1.0, 2.0], "plausible box [-1.0, 2.0] of 'p0' is not inside its hard bounds"),
])
def test_bounds_refused_before_any_model_run(monkeypatch, hard, plausible, fragment) -> None:
    patched = _bounds(hard, plausible)
    monkeypatch.setattr(Problem, "hard_bounds", property(lambda p: patched(p, "hard")))
    monkeypatch.setattr(Problem, "plausible_bounds", property(lambda p: patched(p, "plausible")))
    model = Counting()
    for method in ("vbmc", "emcee", "emulator"):
        with pytest.raises(ValueError, match="identify: .*fix the prior of 'p0'") as info:
            torchshm.identify(problem_of(model), method)
        assert fragment in str(info.value)
    assert model.calls == 0


def test_noise_levels_refused_before_any_model_run() -> None:
    model = Counting()
    problem = problem_of(model)
    problem.sigma_e = -0.1
    with pytest.raises(ValueError, match=r"identify: sigma_e is -0.1; give a finite value >= 0"):
        torchshm.identify(problem, "emcee")
    with pytest.raises(ValueError, match=r"sigma_e = sigma_m = 0 and sigma_a may be 0.*sigma_e > 0"):
        torchshm.identify(problem_of(model, sigma_e=0.0, sigma_m=0.0), "vbmc")
    assert model.calls == 0


@pytest.mark.parametrize("bad", ["shape", "dtype"])
@pytest.mark.parametrize("method", ["vbmc", "emcee", "emulator"])
def test_wrong_output_refused_after_one_model_run(method: str, bad: str) -> None:
    model = Counting(bad)
    with pytest.raises(ValueError, match=f"identify: model output has {bad}.*the model must return") as info:
        torchshm.identify(problem_of(model), method)
    assert "\n" not in str(info.value)
    assert model.calls == 1


def test_output_check_run_is_the_methods_first_run_and_not_repeated() -> None:
    """emcee: the check's run is a cache hit of the first step (VBMC and the emulator find it
    too, but count only their own new runs against their budget: one run more in all)."""
    unchecked, checked = Counting(), Counting()
    options = {"n_walkers": 8, "n_steps": 4}
    with pytest.warns(RuntimeWarning):
        runner("emcee")(problem_of(unchecked), 0, **options)  # the method alone
        post = torchshm.identify(problem_of(checked), "emcee", 0, **options)
    assert checked.calls == unchecked.calls == post.n_model_evaluations  # the check's run counted


def test_parallel_run_without_store_gets_one_in_log_dir(tmp_path: Path, caplog) -> None:
    model = Counting()
    problem = problem_of(model)
    problem.model_outputs(torch.tensor([[1.0, 1.0]]))  # a run made before: copied to the store
    with caplog.at_level(logging.WARNING):
        validate(problem, "emulator", 0, tmp_path / "tb", {"n_jobs": 2})
    path = tmp_path / "tb" / "evaluations.sqlite"
    assert problem.store is not None and problem.store.path == path.resolve()
    assert f"keeps its model runs in {path}" in caplog.text
    assert problem.store.count(model) == 1 and model.calls == 1


def test_options_come_from_the_runners() -> None:
    named, extra = method_options("emulator")
    assert {"batch_size", "max_model_evaluations", "n_jobs", "executor"} <= set(named)
    assert extra == set()
    named, extra = method_options("vbmc")
    assert {"n_samples", "start", "reuse"} == set(named) and "max_fun_evals" in extra
