"""Draws line by line and on a field against the covariance of Eq. (21) computed independently."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.predictive.draws import line_draws
from torchshm.predictive.view import Part, PredictionView
from torchshm.problem.matching import PositionMap

N_DRAWS = 40_000


def matern32(x: np.ndarray, sigma_a: float, length: float) -> np.ndarray:
    """Matérn 3/2 covariance [µε²] of the Euclidean distance between the rows of ``x``."""
    pts = x.reshape(x.shape[0], -1)
    r = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(-1)) * np.sqrt(3.0) / length
    return sigma_a**2 * (1.0 + r) * np.exp(-r)


def empirical(draws: torch.Tensor) -> np.ndarray:
    """Covariance `n x n` of draws `N x 1 x n`."""
    d = draws[:, 0].numpy()
    return np.cov(d, rowvar=False)


def test_two_lines_are_independent_with_their_own_parameters() -> None:
    """Two fibres at the same positions, per-line σa, l and σe: each line's empirical covariance
    is its Eq. (21) block, and the two lines are uncorrelated."""
    x1 = np.linspace(0.0, 1.0, 6)
    x = torch.as_tensor(np.concatenate([x1, x1]))
    view = PredictionView(
        x, np.array(["a"] * 6 + ["b"] * 6, dtype=object), PositionMap(np.arange(12)),
        (Part("a", torch.arange(6), 0, 0.3), Part("b", torch.arange(6, 12), 1, 0.1)),
    )
    eta = torch.linspace(-20.0, 30.0, 12, dtype=torch.float64).expand(N_DRAWS, 1, 12)
    sigma_a = torch.tensor([[2.0, 1.0]], dtype=torch.float64).expand(N_DRAWS, 2)
    length = torch.tensor([[0.5, 0.2]], dtype=torch.float64).expand(N_DRAWS, 2)
    sigma_m = 0.05
    draws = line_draws(view, eta, "matern32", sigma_a, length, sigma_m, torch.Generator().manual_seed(0))
    assert draws.shape == (N_DRAWS, 1, 12)
    cov = empirical(draws)
    e = eta[0, 0].numpy()
    for points, (sa, ell, se) in ((slice(0, 6), (2.0, 0.5, 0.3)), (slice(6, 12), (1.0, 0.2, 0.1))):
        block = matern32(x1, sa, ell) + np.diag(sigma_m**2 * e[points] ** 2 + se**2)
        # sampling error of a covariance entry: sd ~ sqrt((C_ii C_jj + C_ij²) / N) < 5 sd
        tol = 5.0 * np.sqrt(2.0 * np.outer(np.diag(block), np.diag(block)) / N_DRAWS)
        assert np.all(np.abs(cov[points, points] - block) < tol)
        np.testing.assert_allclose(draws[:, 0, points].mean(0).numpy(), e[points],
                                   atol=5 * np.sqrt(np.diag(block).max() / N_DRAWS))
    cross = cov[:6, 6:]
    scale = np.sqrt(np.outer(np.diag(cov)[:6], np.diag(cov)[6:]))
    assert np.abs(cross / scale).max() < 5.0 / np.sqrt(N_DRAWS)  # correlation 0 within 5 sd


def test_field_draws_follow_the_planar_distance() -> None:
    """`n x 2` coordinates: the discrepancy is a function of the distance in the plane."""
    gx, gy = np.meshgrid(np.arange(3) * 0.25, np.arange(2) * 0.25)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    view = PredictionView(torch.as_tensor(xy), None, PositionMap(np.arange(6)), (Part(None, torch.arange(6), 0, 0.5),))
    eta = torch.full((N_DRAWS, 1, 6), 10.0, dtype=torch.float64)
    ones = torch.ones(N_DRAWS, 1, dtype=torch.float64)
    draws = line_draws(view, eta, "matern32", 3.0 * ones, 0.3 * ones, 0.0, torch.Generator().manual_seed(1))
    block = matern32(xy, 3.0, 0.3) + 0.25 * np.eye(6)
    tol = 5.0 * np.sqrt(2.0 * np.outer(np.diag(block), np.diag(block)) / N_DRAWS)
    assert np.all(np.abs(empirical(draws) - block) < tol)


def test_one_line_is_one_call_of_predictive_draws() -> None:
    """The one-fibre path is unchanged: the same numbers as predictive_draws itself."""
    from torchshm.predictive import predictive_draws

    x = torch.linspace(0.0, 2.0, 9, dtype=torch.float64)
    view = PredictionView(x, None, PositionMap(np.arange(9)), (Part(None, torch.arange(9), 0, 0.2),))
    eta = torch.randn(50, 2, 9, generator=torch.Generator().manual_seed(2), dtype=torch.float64)
    sa, ell = torch.full((50, 1), 1.5, dtype=torch.float64), torch.full((50, 1), 0.4, dtype=torch.float64)
    mine = line_draws(view, eta, "matern32", sa, ell, 0.05, torch.Generator().manual_seed(3))
    theirs = predictive_draws(eta, x, "matern32", sa[:, 0], ell[:, 0], 0.05, 0.2, torch.Generator().manual_seed(3))
    assert torch.equal(mine, theirs)


@pytest.mark.parametrize("positions", ["measured", "model"])
def test_view_of_a_two_line_problem(positions: str) -> None:
    """Lines, groups and noise of each part come from the problem (per-line discrepancy)."""
    import torchshm
    from torchshm.predictive import prediction_view

    data = torchshm.synthetic_campaign(0, lines=2).select([24.5])
    problem = torchshm.Problem(torchshm.bridge705(lines=2), data, discrepancy="per_line", sigma_e=None)
    view = prediction_view(problem, positions)
    assert [p.line for p in view.parts] == ["bottom", "top"] and [p.group for p in view.parts] == [0, 1]
    assert sorted(set(view.line.tolist())) == ["bottom", "top"]
    assert sum(p.points.numel() for p in view.parts) == view.x.shape[0]
    with pytest.raises(ValueError, match="positions must be"):
        prediction_view(problem, "nodes")
