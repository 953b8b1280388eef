"""The final step's importance proposal (:mod:`torchshm.inference.adaptive.mixture`) and the
draws made from it (:func:`torchshm.inference.adaptive.draws.posterior_draws`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import logsumexp
from plateau_target import plateau
from scipy.stats import multivariate_normal, norm

from torchshm.inference.adaptive.draws import MIN_ESS, posterior_draws
from torchshm.inference.adaptive.mixture import fit_mixture
from torchshm.inference.adaptive.sampling import importance, transformer


def test_density_is_normalised_and_agrees_with_its_draws_on_a_bounded_support() -> None:
    hard, plausible = np.array([[0.0, 10.0]]), np.array([[1.0, 9.0]])
    rng = np.random.default_rng(0)
    samples = np.clip(rng.normal(7.0, 1.0, (4000, 1)), 0.01, 9.99)
    mix = fit_mixture(samples, transformer(hard, plausible), seed=0)
    pdf = lambda t: float(np.exp(mix.log_pdf(np.array([[t]]))[0]))  # noqa: E731
    total, _ = quad(pdf, 0.0, 10.0, limit=200)
    assert total == pytest.approx(1.0, abs=1e-4)
    mean, _ = quad(lambda t: t * pdf(t), 0.0, 10.0, limit=200)
    draws = mix.sample(200_000, np.random.default_rng(1))
    assert draws.min() > 0.0 and draws.max() < 10.0
    assert draws.mean() == pytest.approx(mean, abs=4 * draws.std() / np.sqrt(draws.shape[0]))
    assert mix.log_pdf(np.array([[-1.0], [11.0]])).tolist() == [-np.inf, -np.inf]


def test_student_t_components_are_normalised_and_sampled_as_their_density() -> None:
    hard, plausible = np.array([[-np.inf, np.inf]]), np.array([[-2.0, 2.0]])
    samples = np.random.default_rng(5).normal(0.5, 0.3, (3000, 1))
    mix = fit_mixture(samples, transformer(hard, plausible), seed=0).widened(2.0, 0.5, df=3.0)
    pdf = lambda t: float(np.exp(mix.log_pdf(np.array([[t]]))[0]))  # noqa: E731
    assert quad(pdf, -np.inf, np.inf, limit=400)[0] == pytest.approx(1.0, abs=1e-4)
    beyond = quad(pdf, 2.5, np.inf, limit=400)[0]  # the t part's tail
    draws = mix.sample(200_000, np.random.default_rng(6))
    assert np.mean(draws > 2.5) == pytest.approx(beyond, abs=4 * np.sqrt(beyond / 200_000))


def test_slabs_reach_a_plateau_the_chain_never_saw() -> None:
    # y: 97 % in a narrow bump at 0, 3 % spread flat over 2..8 (a saturating parameter's
    # plateau); the chain holds the bump only
    hard = np.array([[-np.inf, np.inf], [-10.0, 10.0]])
    plausible = np.array([[-3.0, 3.0], [-9.0, 9.0]])

    rng = np.random.default_rng(7)
    chain = np.column_stack([rng.normal(0.0, 1.0, 4000), rng.normal(0.0, 0.3, 4000)])
    mix = fit_mixture(chain, transformer(hard, plausible), seed=0)
    shares = [float(np.mean(importance(plateau, q, 16000, seed=1).draws[:, 1] > 2.0))
              for q in (mix.widened(), mix.widened().with_slabs(plausible))]
    assert shares[0] < 0.01  # without slabs the plateau is all but lost
    assert shares[1] == pytest.approx(0.03, abs=0.008)


def _two_narrow_modes(rows: np.ndarray) -> np.ndarray:
    """Two modes of equal mass, each sd 1 in x and 0.02 in y, 8 apart in y (labels swap)."""
    cov = np.diag([1.0, 0.02 ** 2])
    a = multivariate_normal([0.0, -4.0], cov).logpdf(rows)
    b = multivariate_normal([0.0, 4.0], cov).logpdf(rows)
    return np.logaddexp(a, b) + np.log(0.5)


def test_anisotropic_modes_far_apart_give_a_full_importance_sample() -> None:
    # the chain holds the modes 80 / 20: the weights restore 50 / 50, and the evidence is 0
    hard = np.array([[-np.inf, np.inf], [-10.0, 10.0]])
    plausible = np.array([[-3.0, 3.0], [-8.0, 8.0]])
    rng = np.random.default_rng(2)
    chain = np.concatenate([rng.normal([0.0, -4.0], [1.0, 0.02], (3200, 2)),
                            rng.normal([0.0, 4.0], [1.0, 0.02], (800, 2))])
    mix = fit_mixture(chain, transformer(hard, plausible), seed=0)
    log_z, sd, ess, draws, khat = importance(_two_narrow_modes, mix.widened(), 8000, seed=0)
    assert ess > 0.3 * 8000 and khat < 0.5
    assert abs(log_z) < 5 * sd + 1e-3 and sd < 0.02
    share = float(np.mean(draws[:, 1] > 0))
    assert share == pytest.approx(0.5, abs=4 * np.sqrt(0.25 / ess))
    assert draws[draws[:, 1] > 0, 1].std() == pytest.approx(0.02, rel=0.1)


def test_a_proposal_that_misses_the_posterior_returns_the_chain_and_warns() -> None:
    # the chain is wide, the target 1000 times narrower: few effective draws
    hard, plausible = np.array([[-np.inf, np.inf]]), np.array([[-3.0, 3.0]])
    chain = np.random.default_rng(3).normal(0.0, 1.0, (3000, 1))

    def narrow(rows: np.ndarray) -> np.ndarray:
        return norm(0.0, 1e-3).logpdf(rows[:, 0])

    with pytest.warns(RuntimeWarning, match="effective draws"):
        out = posterior_draws(narrow, chain, hard, plausible, 2000, seed=0)
    result, vp, source, info = out
    ess, draws = result.ess, result.draws
    assert ess < MIN_ESS and source == "chain" and info["importance_passes"] == 0
    assert draws.shape == (2000, 1) and np.all(np.isin(draws, chain))
    assert np.isfinite(vp.pdf(draws[:5], log_flag=True)).all()


def test_posterior_draws_match_the_target_moments() -> None:
    # a correlated Gaussian target: draws and evidence as the closed form says
    mean, cov = np.array([1.0, 2.0]), np.array([[1.0, 0.9], [0.9, 1.0]])
    target = multivariate_normal(mean, cov)
    hard = np.array([[-np.inf, np.inf], [-np.inf, np.inf]])
    plausible = np.array([[-3.0, 5.0], [-2.0, 6.0]])
    chain = np.random.default_rng(4).multivariate_normal(mean, cov, 3000)
    (log_z, sd, ess, draws, khat), vp, source, info = posterior_draws(
        lambda r: target.logpdf(r) + 3.0, chain, hard, plausible, 8000, seed=1)
    assert khat < 0.5
    assert source == "importance" and ess > 0.5 * 8000
    assert info["importance_passes"] == 0 and info["draws_moment_error"] < 0.03  # one pass will do
    assert log_z == pytest.approx(3.0, abs=max(5 * sd, 0.01))
    assert np.allclose(draws.mean(0), mean, atol=0.05)
    assert np.allclose(np.cov(draws.T), cov, atol=0.06)
    vp_draws, _ = vp.sample(8000)
    assert np.allclose(vp_draws.mean(0), mean, atol=0.1)
    # the stored density is rotated to the mode's shape: the correlation is kept
    assert np.allclose(np.cov(vp_draws.T), cov, atol=0.08)
    assert float(logsumexp(vp.pdf(draws, log_flag=True).ravel() - target.logpdf(draws))
                 - np.log(8000)) == pytest.approx(0.0, abs=0.2)


def test_defensive_is_the_widened_mixture_with_slabs() -> None:
    rng = np.random.default_rng(3)
    box = np.array([[0.0, 1.0], [-2.0, 2.0]])
    fit = fit_mixture(rng.normal([0.5, 0.0], [0.05, 0.2], size=(400, 2)), transformer(box, box), 0)
    one = fit.defensive(box, 3.0, 0.3, 0.2)
    two = fit.widened(3.0, 0.3).with_slabs(box, 0.2)
    x = two.sample(50, rng)
    np.testing.assert_allclose(one.log_pdf(x), two.log_pdf(x), rtol=0, atol=1e-12)
    assert one.weights.sum() == pytest.approx(1.0)
