"""Posterior: summary table, sampling and density, without running an inference method."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm.inference import Posterior


def _normal_posterior(rng: np.random.Generator, n: int = 200_000) -> Posterior:
    samples = rng.normal([1.0, -2.0], [0.5, 3.0], size=(n, 2))
    return Posterior(names=["a", "b"], method="emcee", samples=samples, n_chains=4)


def test_summary_matches_normal_moments_and_quantiles(rng: np.random.Generator) -> None:
    s = _normal_posterior(rng).summary()
    assert [r.name for r in s.rows] == ["a", "b"]
    # 200,000 draws: standard errors ~1e-3 (mean) and ~1e-2 (2.5 % quantile of sd 3)
    assert s["a"].mean == pytest.approx(1.0, abs=5e-3)
    assert s["b"].sd == pytest.approx(3.0, rel=1e-2)
    assert s["a"].q2_5 == pytest.approx(1.0 - 1.959964 * 0.5, abs=1e-2)
    assert s["b"].q97_5 == pytest.approx(-2.0 + 1.959964 * 3.0, abs=5e-2)


def test_summary_csv_and_text(rng: np.random.Generator, tmp_path) -> None:
    s = _normal_posterior(rng, 1000).summary()
    text = s.to_csv(tmp_path / "s.csv")
    lines = (tmp_path / "s.csv").read_text().splitlines()
    assert text.splitlines() == lines
    assert lines[0] == "name,mean,sd,q2.5,q97.5,ess_bulk,r_hat"  # emcee: several chains
    name, mean, *_ = lines[1].split(",")
    assert name == "a" and float(mean) == pytest.approx(s["a"].mean, rel=1e-9)
    assert "parameter" in str(s) and "q97.5" in str(s)
    assert set(s.as_dict()["b"]) == {"mean", "sd", "q2.5", "q97.5", "ess_bulk", "r_hat"}
    with pytest.raises(KeyError, match="no parameter 'c'"):
        s["c"]


def test_emcee_posterior_resamples_its_chain_and_has_no_density(rng: np.random.Generator) -> None:
    post = _normal_posterior(rng, 100)
    draws = post.sample(50, rng=0)
    assert draws.shape == (50, 2)
    rows = {tuple(r) for r in post.samples}
    assert all(tuple(d) in rows for d in draws)
    assert len({tuple(d) for d in draws}) == 50  # without replacement when n <= S
    assert np.array_equal(post.sample(50, rng=0), draws)
    assert post.sample(300, rng=1).shape == (300, 2)
    with pytest.raises(NotImplementedError, match="no density"):
        post.log_pdf(np.zeros(2))


def test_str_flags_non_convergence(rng: np.random.Generator) -> None:
    post = _normal_posterior(rng, 100)
    assert "NOT converged" in str(post)
    post.converged, post.log_evidence, post.log_evidence_sd = True, -3.0, 0.1
    assert "ELBO -3.000 +/- 0.100" in str(post)


def test_single_chain_summary_has_no_chain_diagnostics(rng: np.random.Generator) -> None:
    post = Posterior(names=["a"], method="vbmc", samples=rng.normal(size=(500, 1)))
    s = post.summary()
    assert s.to_csv().splitlines()[0] == "name,mean,sd,q2.5,q97.5"
    assert s["a"].ess_bulk is None and s["a"].r_hat is None


def test_ess_and_rhat_of_independent_and_of_stuck_chains(rng: np.random.Generator) -> None:
    """Independent N(0, 1) draws: ESS ~ S and R-hat ~ 1; chains around different means: R-hat > 2."""
    iid = Posterior(names=["a"], method="emcee", samples=rng.normal(size=(8000, 1)), n_chains=8)
    row = iid.summary()["a"]
    assert 0.85 * 8000 < row.ess_bulk < 1.15 * 8000
    assert abs(row.r_hat - 1.0) < 0.01
    offsets = np.tile(np.arange(8.0), 1000)[:, None]  # step-major: chain c is centred on c
    stuck = Posterior(names=["a"], method="emcee", samples=offsets + 0.1 * rng.normal(size=(8000, 1)),
                      n_chains=8)
    row = stuck.summary()["a"]
    assert row.r_hat > 2.0 and row.ess_bulk < 100  # rank-normalised R-hat; 1.01 is the usual cut


def test_to_arviz_keeps_chains_draws_and_stats(rng: np.random.Generator) -> None:
    samples = rng.normal(size=(60, 2))
    post = Posterior(names=["a", "b"], method="emcee", samples=samples, n_chains=4,
                     sample_stats={"lp": -np.arange(60.0)}, log_evidence=None)
    idata = post.to_arviz()
    import arviz as az

    assert isinstance(idata, az.InferenceData)
    assert idata.posterior["a"].shape == (4, 15)
    # row s * C + c is step s of chain c
    assert idata.posterior["b"].values[2, 5] == samples[5 * 4 + 2, 1]
    assert idata.sample_stats["lp"].values[3, 1] == -(1 * 4 + 3)
    assert idata.posterior.attrs["method"] == "emcee"
    assert float(az.rhat(idata)["a"]) == pytest.approx(post.summary()["a"].r_hat, rel=1e-12)


def test_prior_of_a_posterior_without_problem_comes_from_its_priors() -> None:
    from scipy import stats

    from torchshm import Normal, Uniform

    post = Posterior(names=["a", "b"], method="vbmc", samples=np.zeros((3, 2)),
                     priors={"a": Uniform(0.0, 2.0), "b": Normal(1.0, 2.0), "c": 3.0})
    expected = stats.uniform(0.0, 2.0).logpdf(0.5) + stats.norm(1.0, 2.0).logpdf(-1.0)
    assert post.prior.log_prob(np.array([0.5, -1.0])) == pytest.approx(expected, rel=1e-12)
