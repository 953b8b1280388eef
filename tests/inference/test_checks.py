"""The checks after a fit: posterior mass at a prior bound, the noise model against the data."""

from __future__ import annotations

import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

import torchshm
from torchshm.inference.checks import EDGE, bound_shares, check_fit, warning_tags
from torchshm.inference.posterior import Posterior

from noisy_models import bending_problem

PRIORS = {"E": torchshm.Uniform(10.0, 60.0), "sigma_a": torchshm.Gamma(2.0, 2.0, bounds=(0.0, 5.0))}


def _emcee(problem: torchshm.Problem) -> Posterior:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a short chain: NOT CONVERGED
        return torchshm.identify(problem, method="emcee", seed=0, n_walkers=16, n_steps=300)


def _tags(post: Posterior) -> list[str]:
    return [w.split(":", 1)[0] for w in post.warnings]


def test_noise_model_too_large_is_among_the_first_lines_of_the_summary() -> None:
    # data made with sigma_m = 0.005 and sigma_e = 0.05 µε, identified with the default 0.05
    post = _emcee(bending_problem(sigma_m_data=0.005))
    first = str(post.summary()).splitlines()[: len(post.warnings)]
    noise = [line for line in first if line.startswith("NOISE MODEL")]
    assert len(noise) == 1, post.warnings
    assert "too large" in noise[0] and "sigma_m = 0.05" in noise[0]
    assert "Problem(sigma_m=ts.Gamma(...))" in noise[0]
    assert post.diagnostics["noise_chi2_per_n"] < 0.1  # (0.005 / 0.05)² ~ 0.01 plus noise
    assert post.diagnostics["noise_scatter_ratio"] < 0.05
    assert str(post).splitlines()[0] == post.warnings[0]
    assert post.problem.n_model_evaluations == post.n_model_evaluations  # the checks ran no model


def test_a_clean_fit_gets_neither_check_warning() -> None:
    post = _emcee(bending_problem(sigma_m_data=0.05))
    assert 0.5 < post.diagnostics["noise_chi2_per_n"] < 2.0
    assert 0.5 < post.diagnostics["noise_scatter_ratio"] < 2.0
    assert not {"NOISE MODEL", "PRIOR BOUND"} & set(_tags(post)), post.warnings


def test_the_same_data_with_sigma_m_inferred_get_no_noise_warning() -> None:
    post = _emcee(bending_problem(sigma_m_data=0.005, sigma_m=torchshm.Uniform(0.0, 0.2)))
    assert not {"NOISE MODEL", "PRIOR BOUND"} & set(_tags(post)), post.warnings
    assert 0.5 < post.diagnostics["noise_scatter_ratio"] < 2.0
    assert 0.003 < post.summary()["sigma_m"].mean < 0.007  # the data's 0.005


def test_a_modulus_at_its_prior_bound_is_flagged_and_an_interior_one_is_not() -> None:
    rng = np.random.default_rng(0)
    sigma_a = rng.gamma(20.0, 0.05, 4000)
    at_bound = np.column_stack([60.0 - np.abs(rng.normal(0.0, 1.5, 4000)), sigma_a])
    post = check_fit(Posterior(["E", "sigma_a"], "emcee", at_bound, converged=True, priors=PRIORS))
    assert post.warnings[0].startswith("PRIOR BOUND: E piles at its upper prior bound 60: ")
    assert "saturating" in post.warnings[0] and len(post.warnings) == 1
    assert post.diagnostics["bound_share/E/upper"] == pytest.approx(0.5, abs=0.05)  # |N(0,1.5)| < 1
    assert warning_tags(post.warnings) == "PRIOR BOUND (E upper)"
    interior = np.column_stack([rng.normal(32.0, 1.0, 4000), sigma_a])
    assert check_fit(Posterior(["E", "sigma_a"], "emcee", interior, converged=True,
                               priors=PRIORS)).warnings == []


def test_a_flat_posterior_and_a_discrepancy_scale_near_zero_are_not_flagged() -> None:
    rng = np.random.default_rng(1)
    flat = np.column_stack([rng.uniform(10.0, 60.0, 20_000), rng.uniform(0.0, 0.05, 20_000)])
    post = check_fit(Posterior(["E", "sigma_a"], "emcee", flat, converged=True, priors=PRIORS))
    assert post.warnings == []
    shares = bound_shares(post)
    assert shares[("E", "upper")][0] == pytest.approx(EDGE, abs=0.005)
    assert ("sigma_a", "lower") not in shares  # no model error is a legitimate answer


def test_unconverged_and_warnings_survive_the_file_and_an_old_file_has_none(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    samples = np.column_stack([60.0 - np.abs(rng.normal(0.0, 1.0, 400)), rng.gamma(20.0, 0.05, 400)])
    post = check_fit(Posterior(["E", "sigma_a"], "emcee", samples, converged=False, priors=PRIORS,
                               diagnostics={"n_over_tau": 12.5, "n_steps": 400}, n_chains=8))
    assert _tags(post) == ["NOT CONVERGED", "PRIOR BOUND"]
    assert "12.5 autocorrelation times" in post.warnings[0] and "n_steps" in post.warnings[0]
    csv = post.summary().to_csv(tmp_path / "summary.csv").splitlines()
    assert csv[:2] == [f"# {w}" for w in post.warnings] and csv[2].startswith("name,mean")
    loaded = torchshm.load_posterior(post.save(tmp_path / "p.nc"))
    assert loaded.warnings == post.warnings
    with h5py.File(tmp_path / "p.nc", "a") as fh:  # a file written before warnings existed
        del fh["posterior"].attrs["warnings"]
    assert torchshm.load_posterior(tmp_path / "p.nc").warnings == []
    clean = Posterior(["E", "sigma_a"], "emcee", samples, converged=True)
    assert clean.summary().to_csv().startswith("name,mean")  # a clean run's CSV is unchanged


def test_posterior_mass_beyond_every_model_run_is_flagged_and_mass_among_them_is_not() -> None:
    from torchshm.inference.adaptive.final import beyond_runs

    rng = np.random.default_rng(2)
    box = np.array([[10.0, 60.0], [0.0, 12.0], [0.0, 5.0]])  # E, log10_k, sigma_a
    priors = {**PRIORS, "log10_k": torchshm.Uniform(0.0, 12.0)}
    runs = np.column_stack([rng.uniform(20.0, 50.0, 20), rng.uniform(0.5, 10.0, 20)])
    lo, hi = runs[:, 1].min(), runs[:, 1].max()
    flat_k = np.column_stack([rng.normal(35.0, 1.0, 10_000), rng.uniform(0.0, 12.0, 10_000),
                              rng.gamma(20.0, 0.05, 10_000)])
    found = beyond_runs(flat_k, ["E", "log10_k", "sigma_a"], ["E", "log10_k"], runs, box)
    expected = (max(0.0, lo - 0.6) + max(0.0, 12.0 - hi - 0.6)) / 12.0  # uniform: the share of range
    assert found["beyond_runs"]["log10_k"] == pytest.approx(expected, abs=0.01)
    assert found["beyond_runs"]["E"] == 0.0 and found["runs_range"]["log10_k"] == [lo, hi]
    post = Posterior(["E", "log10_k", "sigma_a"], "emulator", flat_k, converged=True,
                     diagnostics=found, priors=priors)
    assert warning_tags(check_fit(post).warnings) == "EXTRAPOLATION"
    inside = flat_k.copy()
    inside[:, 1] = rng.uniform(lo, hi, 10_000)
    found = beyond_runs(inside, ["E", "log10_k", "sigma_a"], ["E", "log10_k"], runs, box)
    assert found["beyond_runs"]["log10_k"] == 0.0
    assert "EXTRAPOLATION" not in warning_tags(check_fit(Posterior(
        ["E", "log10_k", "sigma_a"], "emulator", inside, converged=True, diagnostics=found,
        priors=priors)).warnings)


def test_an_emulator_posterior_drawn_from_its_chain_is_flagged_and_one_drawn_by_weight_is_not() -> None:
    rng = np.random.default_rng(3)
    samples = np.column_stack([rng.normal(35.0, 1.0, 4000), rng.gamma(20.0, 0.05, 4000)])

    def checked(source: str) -> str:
        post = Posterior(["E", "sigma_a"], "emulator", samples, converged=True, priors=PRIORS,
                         diagnostics={"posterior_draws": source, "evidence_ess": 57.0})
        return warning_tags(check_fit(post).warnings)

    assert checked("chain") == "EVIDENCE"
    assert checked("importance") == ""


def test_emulator_draws_with_an_uncertain_moment_are_flagged() -> None:
    rng = np.random.default_rng(4)
    samples = np.column_stack([rng.normal(35.0, 1.0, 4000), rng.gamma(20.0, 0.05, 4000)])

    def checked(error: float) -> str:
        post = Posterior(["E", "sigma_a"], "emulator", samples, converged=True, priors=PRIORS,
                         diagnostics={"posterior_draws": "importance", "evidence_ess": 5000.0,
                                      "importance_passes": 2, "draws_moment_error": error})
        return warning_tags(check_fit(post).warnings)

    assert checked(0.15) == "EVIDENCE"
    assert checked(0.02) == ""
