"""Bayes factors from ELBOs and Jeffreys' labels (Sec. 2.4.2, Tables 1 and 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from torchshm.predictive import bayes_factors, jeffreys_label


@pytest.mark.parametrize(
    ("log10_b", "label"),
    [(-0.1, "Negative"), (0.0, "Barely worth mentioning"), (0.49, "Barely worth mentioning"),
     (0.5, "Substantial"), (1.2, "Strong"), (1.7, "Very strong"), (2.0, "Decisive"), (40, "Decisive")],
)
def test_jeffreys_scale(log10_b: float, label: str) -> None:
    assert jeffreys_label(log10_b) == label


def linear_gaussian_log_evidence(y: np.ndarray, g: np.ndarray, prior_sd: float, noise_sd: float) -> float:
    """log p(y) for y = g * theta + e, theta ~ N(0, prior_sd²), e ~ N(0, noise_sd² I)."""
    cov = prior_sd**2 * np.outer(g, g) + noise_sd**2 * np.eye(y.size)
    return float(stats.multivariate_normal(np.zeros(y.size), cov).logpdf(y))


def test_known_evidences() -> None:
    rng = np.random.default_rng(0)
    x = np.linspace(0, 1, 20)
    y = 2.0 * x + 0.1 * rng.standard_normal(20)
    ev_good = linear_gaussian_log_evidence(y, x, 3.0, 0.1)
    ev_bad = linear_gaussian_log_evidence(y, x**3, 3.0, 0.1)
    bf = bayes_factors({"linear": (ev_good, 0.02), "cubic": (ev_bad, 0.03)})
    expected = (ev_good - ev_bad) / math.log(10)
    assert bf.log10[0, 1] == pytest.approx(expected, abs=1e-12)
    assert bf.log10[1, 0] == pytest.approx(-expected, abs=1e-12)
    assert bf.labels[0][1] == jeffreys_label(expected) and bf.labels[1][0] == "Negative"
    half = 1.96 * math.hypot(0.02, 0.03) / math.log(10)
    assert bf.upper[0, 1] - bf.log10[0, 1] == pytest.approx(half)


def test_tables_and_errors() -> None:
    class Post:
        log_evidence, log_evidence_sd = -100.0, 0.1

    bf = bayes_factors({"B1": Post(), "B3": (-80.0, 0.2), "B4": -81.0})
    text = bf.to_markdown()
    assert text.splitlines()[0] == "| model | B1 | B3 | B4 |"
    assert "Decisive (+8.69" in text and "| B1 | – |" in text
    csv = bf.to_csv()
    assert csv.splitlines()[0] == "model_i,model_j,log10_B,lower,upper,label"
    assert len(csv.splitlines()) == 1 + 6
    assert np.isnan(bf.lower[1, 2])  # B4 has no sd

    class Emcee:
        log_evidence = None

    with pytest.raises(ValueError, match="no log evidence"):
        bayes_factors({"a": Emcee(), "b": -1.0})
    with pytest.raises(ValueError, match="at least two"):
        bayes_factors({"a": -1.0})


def test_nan_evidence_is_undefined_not_decisive() -> None:
    from torchshm.predictive import bayes_factors

    bf = bayes_factors({"a": float("nan"), "b": np.float32(-3.0)})
    assert bf.labels[0][1] == "undefined" and bf.labels[1][0] == "undefined"
    with pytest.raises(ValueError, match="has no log evidence"):
        bayes_factors({"a": (None, None), "b": -1.0})
