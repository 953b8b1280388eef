"""identify() on a linear-Gaussian problem with an analytic posterior and evidence.

The forward model is user-defined and linear in two physical parameters with Normal priors;
``sigma_a`` is fixed, the kernel is ``independent`` and ``sigma_m = 0``, so the posterior is
Gaussian and the log evidence is known in closed form (``inference_models``). Fixed seeds.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from inference_models import LinearModel, linear_gaussian_answer, linear_gaussian_problem
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from torchshm import identify
from torchshm.inference import Posterior


@pytest.fixture(scope="module")
def answer() -> tuple[np.ndarray, np.ndarray, float]:
    return linear_gaussian_answer(linear_gaussian_problem())


@pytest.fixture(scope="module")
def vbmc_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Posterior, str]:
    log_dir = str(tmp_path_factory.mktemp("tb_vbmc"))
    post = identify(linear_gaussian_problem(), "vbmc", seed=0, log_dir=log_dir, display="off")
    return post, log_dir


@pytest.fixture(scope="module")
def emcee_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Posterior, str]:
    log_dir = str(tmp_path_factory.mktemp("tb_emcee"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # N/tau < 50 is flagged, tested below
        post = identify(linear_gaussian_problem(), "emcee", seed=0, log_dir=log_dir)
    return post, log_dir


def _check_moments(post: Posterior, mean: np.ndarray, cov: np.ndarray) -> None:
    """Acceptance: means within 0.1 posterior sd, sds within 10 %."""
    sd = np.sqrt(np.diag(cov))
    s = post.summary()
    got_mean = np.array([r.mean for r in s.rows])
    got_sd = np.array([r.sd for r in s.rows])
    assert np.all(np.abs(got_mean - mean) < 0.1 * sd), (got_mean, mean, sd)
    assert np.all(np.abs(got_sd / sd - 1.0) < 0.10), (got_sd, sd)


def test_vbmc_matches_the_analytic_posterior_and_evidence(vbmc_run, answer) -> None:
    post, _ = vbmc_run
    mean, cov, log_evidence = answer
    assert post.method == "vbmc" and post.converged
    _check_moments(post, mean, cov)
    assert abs(post.log_evidence - log_evidence) < 0.2
    assert 0 <= post.log_evidence_sd < 0.2
    # the variational density is the analytic Gaussian near the mode (within ~0.1 nats)
    theta = mean + np.array([[0.0, 0.0], [1.0, -1.0], [-0.5, 1.5]]) * np.sqrt(np.diag(cov))
    diff = theta - mean
    exact = -0.5 * np.einsum("ni,ij,nj->n", diff, np.linalg.inv(cov), diff) - 0.5 * np.log(
        np.linalg.det(2 * np.pi * cov))
    assert np.allclose(post.log_pdf(theta), exact, atol=0.1)


def test_vbmc_counts_and_reports(vbmc_run) -> None:
    post, _ = vbmc_run
    d = post.diagnostics
    assert 0 < post.n_model_evaluations <= d["n_log_joint_evaluations"]
    assert post.n_model_evaluations <= 50 * (2 + 2)  # PyVBMC's max_fun_evals, search included
    # model calls of the search: Latin hypercube (10), Nelder-Mead (<= 20), probes (<= 2 x 6)
    assert 10 < d["n_start_evaluations"] <= 10 + 10 * 2 + 2 * 6
    assert d["n_start_evaluations"] + d["vbmc_func_count"] + d["n_check_evaluations"] >= post.n_model_evaluations
    assert post.samples.shape == (100_000, 2)
    assert set(post.priors) == {"p0", "p1", "sigma_a"}
    h = post.history
    assert np.array_equal(h["iteration"], np.arange(d["iterations"]))
    assert np.all(np.diff(h["n_evaluations"]) >= 0)
    assert np.all(h["p0/q2.5"] < h["p0/mean"]) and np.all(h["p0/mean"] < h["p0/q97.5"])


def test_tensorboard_has_one_elbo_per_vbmc_iteration(vbmc_run) -> None:
    post, log_dir = vbmc_run
    acc = EventAccumulator(log_dir)
    acc.Reload()
    tags = set(acc.Tags()["scalars"])
    assert {"elbo", "elbo_sd", "sKL", "n_evaluations", "p0/mean", "p0/q2.5", "p1/q97.5"} <= tags
    elbo = acc.Scalars("elbo")
    assert [e.step for e in elbo] == list(range(post.diagnostics["iterations"]))
    assert np.allclose([e.value for e in elbo], post.history["elbo"], rtol=1e-6)


def test_emcee_matches_the_analytic_posterior(emcee_run, answer) -> None:
    post, _ = emcee_run
    mean, cov, _ = answer
    assert post.method == "emcee" and post.log_evidence is None and post.log_evidence_sd is None
    _check_moments(post, mean, cov)
    d = post.diagnostics
    assert post.samples.shape == (40 * 1000, 2)  # 40 walkers x (2000 - 1000 burn-in) steps
    assert 0.2 < d["acceptance_fraction"] < 0.9
    assert 5 < d["tau_max"] < 100
    assert d["n_over_tau"] == pytest.approx(1000 / d["tau_max"])
    assert post.converged == (d["n_over_tau"] >= 50)
    assert post.n_model_evaluations == d["n_log_joint_evaluations"] == 40 * 2001
    assert post.sample_stats["lp"].shape == (40_000,)


def test_emcee_tensorboard_running_marginals(emcee_run) -> None:
    post, log_dir = emcee_run
    acc = EventAccumulator(log_dir)
    acc.Reload()
    events = acc.Scalars("p0/mean")
    assert [e.step for e in events] == [40 * s for s in range(100, 2001, 100)]
    assert {"acceptance_fraction", "tau_max", "p1/q2.5", "p1/q97.5"} <= set(acc.Tags()["scalars"])
    chain = post.samples.reshape(1000, 40, 2)
    last = chain[-25:].reshape(-1, 2)  # the last 1,000 samples: 25 steps x 40 walkers
    assert events[-1].value == pytest.approx(last[:, 0].mean(), rel=1e-6)


def test_unknown_method_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown method 'nuts'"):
        identify(linear_gaussian_problem(), "nuts")


def test_vbmc_out_of_budget_is_flagged_and_warned() -> None:
    with pytest.warns(RuntimeWarning, match="did not converge"):
        post = identify(linear_gaussian_problem(), "vbmc", seed=1, max_fun_evals=30, display="off")
    assert not post.converged
    assert post.diagnostics["convergence_status"] == "no"
    assert post.n_model_evaluations <= 30


class _FailingModel(LinearModel):
    """Raises for p0 < -0.3: a model run that crashes, far from the posterior (p0 ~ 1.3)."""

    def __call__(self, theta_p):
        if bool((theta_p[..., 0] < -0.3).any()):
            raise RuntimeError("solver diverged")
        return super().__call__(theta_p)


@pytest.mark.parametrize("method", ["vbmc", "emcee"])
def test_failed_model_runs_do_not_end_the_study(method: str, answer) -> None:
    problem = linear_gaussian_problem(model=_FailingModel())
    options = {"display": "off"} if method == "vbmc" else {"n_walkers": 16, "n_steps": 300, "burn": 150}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        post = identify(problem, method, seed=2, **options)
    assert post.diagnostics["n_failed_evaluations"] > 0
    if method == "vbmc":
        assert any("solver diverged" in str(w.message) for w in caught)
        mean, cov, _ = answer
        _check_moments(post, mean, cov)
    assert abs(post.summary()["p0"].mean - 1.3) < 0.2
