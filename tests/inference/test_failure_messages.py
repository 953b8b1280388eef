"""Messages of failing model runs and bad budgets (issue: every message exact, one line)."""

from __future__ import annotations

import warnings

import emcee
import numpy as np
import pytest
import torch

from inference_models import LinearModel, linear_gaussian_problem
from torchshm import identify
from torchshm.inference import mcmc
from torchshm.inference.start import vbmc_budget
from torchshm.inference.target import LogJointTarget, ModelRunsFailed


class _NaN(LinearModel):
    def __call__(self, theta_p):
        return super().__call__(theta_p) * float("nan")


class _WrongShape(LinearModel):
    def __call__(self, theta_p):
        return super().__call__(theta_p)[..., :5]


class _Raises(LinearModel):
    def __call__(self, theta_p):
        raise RuntimeError("solver diverged")


CASES = [(_NaN, "NaN"), (_WrongShape, "shape (2, 5)"), (_Raises, "RuntimeError: solver diverged")]


@pytest.mark.parametrize("store", [False, True])
@pytest.mark.parametrize("model, fragment", CASES)
def test_log_joint_never_raises(model, fragment: str, store: bool, tmp_path) -> None:
    problem = linear_gaussian_problem(model=model(), store=tmp_path / "s.db" if store else None)
    value = problem.log_joint(np.array([[1.0, 2.0], [0.5, 0.5]]))
    assert np.all(value == -np.inf)
    errors = problem.failures()[1]
    assert errors and any(fragment in e for e in errors), errors


@pytest.mark.parametrize("store", [False, True])
@pytest.mark.parametrize("model, fragment", CASES)
def test_every_run_failed_is_one_line_quoting_the_error(model, fragment: str, store: bool, tmp_path) -> None:
    problem = linear_gaussian_problem(model=model(), store=tmp_path / "s.db" if store else None)
    # a wrong output shape is refused by the check before the method, after one run
    expected = ValueError if model is _WrongShape else ModelRunsFailed
    with pytest.raises(expected) as info:
        identify(problem, "vbmc", max_fun_evals=20, display="off")
    message = str(info.value)
    assert "\n" not in message and fragment in message and "see the evaluation store" not in message
    # the first batch (the start design: 10 points), each point again alone when the batch failed
    assert problem.n_model_evaluations <= 20


def test_emcee_with_every_run_failed_stops_at_the_first_step() -> None:
    problem = linear_gaussian_problem(model=_Raises())
    with pytest.raises(ModelRunsFailed, match="solver diverged"):
        identify(problem, "emcee", n_walkers=8, n_steps=50)


def test_some_failures_warn_with_the_first_error() -> None:
    target = LogJointTarget(linear_gaussian_problem(model=_Raises()), impute_failures=True)
    target.y.append(-1.0)  # a finite value seen before: failures are imputed, not fatal
    target.X.append(np.zeros(2))
    assert target.evaluate(np.array([[1.0, 1.0]]))[0] == -1.0
    assert target.error_text() == "RuntimeError: solver diverged"


def test_no_error_recorded_says_so() -> None:
    class Nothing:
        names = ["a"]

        def log_joint(self, theta):
            return np.full(len(theta), np.nan)

    target = LogJointTarget(Nothing(), impute_failures=True, hard_bounds=np.array([[-1.0, 1.0]]))
    with pytest.raises(ModelRunsFailed, match="no model error was recorded"):
        target.evaluate(np.zeros((1, 1)))


def test_budget_none_is_pyvbmc_default_and_too_small_is_refused_before_any_run() -> None:
    assert vbmc_budget(2, {"max_fun_evals": None}) == 200 == vbmc_budget(2, {})
    problem = linear_gaussian_problem()
    for bad, fragment in [(10, "must be at least 20 for 2 parameters"), (2.5, "must be an integer")]:
        with pytest.raises(ValueError, match=fragment) as info:
            identify(problem, "vbmc", max_fun_evals=bad, display="off")
        assert "max_fun_evals (method.max_fun_evals)" in str(info.value)
    assert problem.n_model_evaluations == 0


@pytest.mark.slow
def test_max_fun_evals_none_runs() -> None:
    post = identify(linear_gaussian_problem(), "vbmc", max_fun_evals=None, display="off", n_samples=1000)
    assert post.converged and post.n_model_evaluations <= 200


def test_stuck_walker_is_flagged() -> None:
    acceptance = np.r_[np.full(39, 0.31), 0.047]
    assert mcmc.stuck_walkers(acceptance).tolist() == [39]
    assert mcmc.stuck_walkers(np.full(40, 0.05)).tolist() == []  # uniformly low: the tau rule speaks


def test_stuck_walker_in_a_chain_warns_and_is_in_the_diagnostics() -> None:
    n_walkers, n_steps = 10, 200
    backend = emcee.backends.Backend()
    backend.reset(n_walkers, 2)
    backend.grow(n_steps, None)
    rng = np.random.default_rng(0)
    coords = np.zeros((n_walkers, 2))
    for step in range(n_steps):
        accepted = rng.random(n_walkers) < 0.3
        accepted[4] = step % 20 == 0  # 5 % acceptance
        coords = coords + accepted[:, None] * rng.standard_normal((n_walkers, 2))
        backend.save_step(emcee.State(coords, log_prob=-np.sum(coords**2, axis=1)), accepted)

    class Problem:
        names = ["a", "b"]
        n_model_evaluations = 0
        priors: dict = {}

    class Trace:
        def history(self):
            return {}

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        post = mcmc._posterior(Problem(), backend, Trace(), LogJointTarget(Problem()), 0, 100, 1, {})
    assert post.diagnostics["stuck_walkers"] == [4] and post.diagnostics["n_stuck_walkers"] == 1
    assert any("walker(s) 4 (0.050)" in str(w.message) for w in caught), [str(w.message) for w in caught]
