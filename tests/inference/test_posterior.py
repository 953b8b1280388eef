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
    assert lines[0] == "name,mean,sd,q2.5,q97.5"
    name, mean, *_ = lines[1].split(",")
    assert name == "a" and float(mean) == pytest.approx(s["a"].mean, rel=1e-9)
    assert "parameter" in str(s) and "q97.5" in str(s)
    assert set(s.as_dict()["b"]) == {"mean", "sd", "q2.5", "q97.5"}
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
