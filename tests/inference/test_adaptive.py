"""method="emulator" (torchshm.inference.adaptive) against analytic answers, small budgets.

The linear-Gaussian problem of ``inference_models`` has a Gaussian posterior and a closed-form
evidence and KL divergence; the emulator must reproduce them with a handful of model runs.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch
from inference_models import LinearModel, linear_gaussian_answer, linear_gaussian_problem
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

import torchshm
from torchshm.inference import Posterior
from torchshm.inference.adaptive.acquisition import choose_batch
from torchshm.inference.adaptive.field import FieldEmulator
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint
from torchshm.inference.adaptive.method import default_n_initial
from torchshm.inference.adaptive.sampling import regroup, straggler_gap, total_variation

SMALL = {"n_walkers": 16, "n_steps": 100, "final_steps": 300, "n_evidence": 2000}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Posterior, str, object]:
    log_dir = str(tmp_path_factory.mktemp("tb_emulator"))
    problem = linear_gaussian_problem()
    post = torchshm.identify(problem, "emulator", seed=0, log_dir=log_dir, **SMALL)
    return post, log_dir, problem


def test_posterior_and_evidence_match_the_analytic_answer(run: tuple) -> None:
    post, _, problem = run
    mean, cov, log_z = linear_gaussian_answer(problem)
    sd = np.sqrt(np.diag(cov))
    summary = post.summary()
    for i, name in enumerate(post.names):
        assert abs(summary[name].mean - mean[i]) < 0.15 * sd[i]
        assert abs(summary[name].sd / sd[i] - 1) < 0.15
    assert abs(post.log_evidence - log_z) < 0.3  # acceptance point 2
    assert 0 < post.log_evidence_sd < 0.1
    assert post.converged and post.method == "emulator"
    checked = post.diagnostics["n_check_evaluations"]  # the output check's run (identify)
    assert post.n_model_evaluations <= 15 + checked
    rounds = post.diagnostics["rounds"]
    assert sum(int(r["n_new_runs"]) for r in rounds) + checked == post.n_model_evaluations
    assert len(rounds[0]["batch"]) == default_n_initial(2, 5) == 5  # the design: one batch
    assert all(len(r["batch"]) <= 5 for r in rounds[1:])
    assert all(r["cpu_time_s"] > 0 for r in rounds) and post.diagnostics["final_cpu_time_s"] > 0


def test_density_kl_and_predictive_make_no_model_run(run: tuple) -> None:
    post, _, problem = run
    mean, cov, _ = linear_gaussian_answer(problem)
    before = problem.n_model_evaluations
    s0 = np.diag([problem.priors[n].sd ** 2 for n in post.names])
    m0 = np.array([problem.priors[n].mean for n in post.names])
    d = m0 - mean
    exact_kl = 0.5 * (np.trace(np.linalg.solve(s0, cov)) + d @ np.linalg.solve(s0, d) - 2
                      + np.log(np.linalg.det(s0) / np.linalg.det(cov)))
    kl = torchshm.kl_divergence(post, n=4000)
    assert abs(kl - exact_kl) < 0.1
    pred = torchshm.posterior_predictive(post, [20.0], n=200)
    assert pred.mean.shape == (1, 60)
    assert problem.n_model_evaluations == before


def test_tensorboard_has_one_row_per_round(run: tuple) -> None:
    post, log_dir, _ = run
    acc = EventAccumulator(log_dir)
    acc.Reload()
    tags = acc.Tags()["scalars"]
    for tag in ("tv", "mmtv", "emulator_share", "n_model_evaluations", "p0/mean", "p0/q97.5"):
        assert tag in tags
    assert len(acc.Scalars("tv")) == post.diagnostics["n_rounds"]


def test_failed_runs_are_left_out_and_counted() -> None:
    class Failing(LinearModel):
        identity = "failing-linear"

        def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
            theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
            if bool((theta_p[..., 0] > 0.6).any()):
                raise RuntimeError("solver diverged")
            return super().__call__(theta_p)

    problem = linear_gaussian_problem(truth=(0.3, -0.2), model=Failing())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        post = torchshm.identify(problem, "emulator", seed=1, max_model_evaluations=8,
                                 n_walkers=12, n_steps=60, final_steps=100, n_evidence=500)
    assert post.diagnostics["n_failed_evaluations"] >= 1
    assert np.isfinite(post.summary()["p0"].mean)


def test_batch_rule_spreads_the_points() -> None:
    x = torch.linspace(0, 1, 20, dtype=torch.float64)
    theta = np.array([[0.0], [0.5], [1.0], [0.25]])
    outputs = np.sin(3 * theta[:, :, None] * x.numpy()[None, None, :])
    emulator = FieldEmulator.fit(theta, outputs, x, torch.tensor([1.0]))
    cand = np.linspace(0, 1, 401)[:, None]
    variance = np.diag(emulator.latent_covariance(*(torch.as_tensor(cand),) * 2).numpy())
    batch, index = choose_batch(emulator, cand, variance, 3, np.random.default_rng(0))
    assert batch.shape == (3, 1) and np.array_equal(cand[index], batch)
    dist = np.abs(batch[:, None, 0] - np.vstack([batch, theta])[None, :, 0])
    np.fill_diagonal(dist[:, :3], np.inf)
    assert dist.min() > 0.05  # no two runs on top of each other or of the design


def test_emulated_log_joint_is_exact_where_the_emulator_is_exact() -> None:
    problem = linear_gaussian_problem()
    theta = np.array([[1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [-1.0, -1.0], [0.0, 0.0]])
    # the ARD kernel alone, whose long-lengthscale limit is exact for a linear model; with the
    # default additive term, five runs let the marginal likelihood prefer the additive terms at
    # lengthscale 1.25 (field off by 0.2 of 1.9 µε at these points, the log joint by 7-16 nats)
    emulator = FieldEmulator.fit(theta, np.asarray(problem.model_outputs(theta)),
                                 torch.as_tensor(problem.measurements.x),
                                 torch.as_tensor(problem.measurements.loads), kernel="matern52")
    log_joint = EmulatedLogJoint(problem, emulator)
    at = np.array([[1.3, -0.7], [0.2, 0.4]])
    np.testing.assert_allclose(log_joint(at), problem.log_joint(at), atol=0.05)
    assert total_variation(log_joint(at), log_joint(at)) == 0.0


def test_stranded_walkers_are_moved_onto_good_ones() -> None:
    def log_density(x: np.ndarray) -> np.ndarray:
        return -0.5 * np.square(x).sum(-1)

    assert straggler_gap(2) == pytest.approx(np.log(1e6))  # chi2 with 2 dof: -2 log(tail)
    walkers = np.random.default_rng(0).standard_normal((8, 2))
    walkers[3] = [40.0, 0.0]  # 800 nats below the others
    moved = regroup(log_density, walkers, seed=0)
    assert np.all(np.abs(moved[3]) < 4) and not np.any(np.all(moved[3] == walkers, axis=1))
    np.testing.assert_array_equal(np.delete(moved, 3, 0), np.delete(walkers, 3, 0))
    assert regroup(log_density, moved, seed=0) is moved  # none stranded: left as they are


def test_bad_options_are_named() -> None:
    problem = linear_gaussian_problem()
    with pytest.raises(ValueError, match="batch_size"):
        torchshm.identify(problem, "emulator", batch_size=0)
    with pytest.raises(ValueError, match="n_jobs"):  # n_jobs=2 without a store gets one
        torchshm.identify(problem, "emulator", n_jobs=0)  # (tests/inference/test_validate.py)


def test_cli_config_selects_the_method() -> None:
    from hydra import compose, initialize_config_dir

    from torchshm.config import CONF_DIR, CONFIG_NAME, method_options, register_configs, to_settings

    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(CONFIG_NAME, overrides=["method=emulator", "method.batch_size=4"])
    settings = to_settings(cfg)
    options = method_options(settings.method)
    assert settings.method.name == "emulator"
    assert options["batch_size"] == 4 and options["tv_tol"] == 0.05
    assert "max_model_evaluations" not in options  # None: the method's default budget


def test_the_output_check_run_is_the_first_design_run() -> None:
    """identify's output check runs the model once before the method; that run is the first
    point of the emulator's initial design, so the design makes one run fewer and the budget
    is not exceeded (a 10-minute model: the check is not an extra 10 minutes)."""
    calls: list[int] = []

    class Counting(LinearModel):
        def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
            theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
            calls.append(int(np.prod(theta_p.shape[:-1])) if theta_p.ndim > 1 else 1)
            return super().__call__(theta_p)

    problem = linear_gaussian_problem(model=Counting())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        post = torchshm.identify(problem, "emulator", seed=0, max_model_evaluations=12, **SMALL)
    first = post.diagnostics["rounds"][0]
    assert calls[0] == 1 and post.diagnostics["n_reused_runs"] == 1  # the check, then the method
    design = default_n_initial(len(problem.physical_names), 5)
    assert first["n_runs"] == design and first["n_new_runs"] == design - 1  # it holds the check's run
    assert sum(calls) == post.n_model_evaluations <= 12


def test_default_design_is_the_smallest_multiple_of_the_batch_of_at_least_2p_plus_1() -> None:
    """One batch of 5 for two physical parameters, two for three to four, three for six."""
    assert [default_n_initial(p, 5) for p in (1, 2, 3, 4, 6)] == [5, 5, 10, 10, 15]
    assert default_n_initial(2, 1) == 5 and default_n_initial(2, 2) == 6 and default_n_initial(2, 10) == 10
