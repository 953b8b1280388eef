"""The paper's priors: Table 2 distributions with Table 4 bounds."""

from __future__ import annotations

import numpy as np
from scipy import stats

import torchshm
from torchshm import Gamma, Uniform, paper_priors


def test_table2_and_table4() -> None:
    priors = paper_priors()
    assert list(priors) == ["E_c", "log10_K_r", "sigma_a", "length"]
    assert isinstance(priors["E_c"], Uniform) and (priors["E_c"].a, priors["E_c"].b) == (
        10.0,
        100.0,
    )
    assert isinstance(priors["log10_K_r"], Uniform) and (
        priors["log10_K_r"].a,
        priors["log10_K_r"].b,
    ) == (0.0, 12.0)
    assert isinstance(priors["sigma_a"], Gamma) and (
        priors["sigma_a"].alpha,
        priors["sigma_a"].beta,
    ) == (2.0, 2.0)
    assert isinstance(priors["length"], Gamma) and (
        priors["length"].alpha,
        priors["length"].beta,
    ) == (3.0, 1.0)
    hard = {k: p.hard_bounds for k, p in priors.items()}
    plausible = {k: p.plausible_bounds for k, p in priors.items()}
    assert hard == {"E_c": (10, 100), "log10_K_r": (0, 12), "sigma_a": (0, 5), "length": (0, 10)}
    assert plausible == {
        "E_c": (20, 60),
        "log10_K_r": (1, 11),
        "sigma_a": (0.2, 2.0),
        "length": (0.2, 5.0),
    }


def test_beta_is_the_rate() -> None:
    """Gamma(2, 2) has mean 1 µε; Gamma(3, 1) has mean 3 m (before truncation)."""
    sigma_a = paper_priors()["sigma_a"]
    x = np.array([0.3, 1.0, 2.5])
    mass = stats.gamma(2.0, scale=0.5).cdf(5.0)
    np.testing.assert_allclose(
        sigma_a.log_prob(x), stats.gamma(2.0, scale=0.5).logpdf(x) - np.log(mass), rtol=1e-13
    )


def test_fresh_dict_each_call() -> None:
    a = paper_priors()
    a.pop("length")
    assert "length" in paper_priors()


def test_public_names() -> None:
    assert torchshm.paper_priors is paper_priors and torchshm.Uniform is Uniform
    assert torchshm.Normal.__name__ == "Normal" and torchshm.Gamma is Gamma
