"""Ordering and nearest previous neighbours of the Vecchia form, against brute force."""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist

from torchshm.likelihood import neighbours


def test_previous_neighbours_are_the_nearest_earlier_points(rng: np.random.Generator) -> None:
    x = rng.uniform(0.0, 3.0, (700, 2))
    got = neighbours.previous_neighbours(x, 7)
    dist = cdist(x, x)
    for i in range(700):
        expected = np.argsort(dist[i, :i], kind="stable")[:7]
        assert np.array_equal(got[i, : expected.size], expected), i
        assert (got[i, expected.size :] == -1).all()


def test_coarse_to_fine_starts_spread_and_is_a_permutation() -> None:
    g = np.linspace(0.0, 1.0, 40)
    x = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    order = neighbours.coarse_to_fine(x)
    assert np.array_equal(np.sort(order), np.arange(x.shape[0]))
    first = x[order[:16]]  # the first points cover the square: every quadrant has some
    assert len({(bool(a < 0.5), bool(b < 0.5)) for a, b in first}) == 4
    assert np.linalg.norm(x[order[0]] - 0.5) < 0.02


def test_plan_is_cached_and_lower_distances_match(rng: np.random.Generator) -> None:
    x = rng.uniform(0.0, 1.0, (300, 2))
    plan = neighbours.plan(x, 5)
    assert neighbours.plan(x.copy(), 5) is plan
    xo = x[plan.order]
    rows, cols = np.tril_indices(6, -1)
    i = 200
    block = plan.blocks[i]
    assert block[-1] == i and (block[:-1] < i).all()
    expected = np.linalg.norm(xo[block[rows]] - xo[block[cols]], axis=1)
    np.testing.assert_allclose(plan.lower[i], expected, rtol=1e-14)
