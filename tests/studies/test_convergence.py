"""Convergence measures of study A against hand-computed answers."""

from __future__ import annotations

import numpy as np
import pytest

from convergence import compare_marginals, half_chain_means, stabilisation_point, window_stats


def step_chain(steps: int = 10, walkers: int = 4, dim: int = 2) -> np.ndarray:
    """chain[s, w, d] = s + 10 d + 0.1 w: known means per step."""
    s, w, d = np.meshgrid(np.arange(steps), np.arange(walkers), np.arange(dim), indexing="ij")
    return (s + 10 * d + 0.1 * w).astype(np.float64)


def test_window_stats_uses_the_last_whole_steps() -> None:
    chain = step_chain()
    n, mean, lower, upper = window_stats(chain, window=8)  # 8 samples = 2 steps of 4 walkers
    assert np.array_equal(n, np.arange(1, 11) * 4)
    assert mean[0] == pytest.approx([0.15, 10.15])  # first step alone
    assert mean[5] == pytest.approx([4.65, 14.65])  # steps 4 and 5
    assert np.all(lower <= mean) and np.all(mean <= upper)


def test_half_chain_means_match_brute_force() -> None:
    chain = np.random.default_rng(0).normal(size=(17, 3, 2))
    n, means = half_chain_means(chain)
    for s in range(17):
        ends = s + 1
        expected = chain[ends // 2 : ends].reshape(-1, 2).mean(axis=0)
        assert means[s] == pytest.approx(expected, abs=1e-12)
    assert n[-1] == 17 * 3


def test_stabilisation_point() -> None:
    n = np.array([10, 20, 30, 40, 50])
    est = np.array([[5.0, 0.0], [0.05, 0.0], [0.3, 0.0], [0.05, -0.08], [0.0, 0.0]])
    final, sd = np.zeros(2), np.ones(2)
    assert stabilisation_point(n, est, final, sd, tol=0.1) == 40  # 30 is outside for param 0
    assert stabilisation_point(n, est, final, sd, tol=0.5) == 20
    assert stabilisation_point(n, est, final, sd, tol=10) == 10
    est[-1, 1] = 1.0
    assert stabilisation_point(n, est, final, sd, tol=0.1) is None


def test_compare_marginals() -> None:
    rng = np.random.default_rng(1)
    ref = rng.normal([1.0, 10.0], [2.0, 1.0], size=(200_000, 2))
    other = rng.normal([1.2, 10.0], [2.0, 1.5], size=(200_000, 2))
    rows = compare_marginals(["a", "b"], ref, other)
    assert rows[0].mean_shift == pytest.approx(0.1, abs=0.02)
    assert rows[1].sd_ratio == pytest.approx(1.5, abs=0.02)
    assert [r.name for r in rows] == ["a", "b"]
