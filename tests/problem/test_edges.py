"""Sub-case C1 size (11 load cases x 351 points): finite everywhere on the hard-bounds box."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch

from torchshm import Problem, Uniform, log_likelihood, paper_priors
from torchshm.kernels import KERNELS


def corners_and_edge_midpoints(bounds: np.ndarray) -> np.ndarray:
    """`(2^D + D 2^(D-1)) x D` corners and midpoints of the edges of a box `D x 2`."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    levels = [(0.0, 1.0)] * len(lo)
    corners = np.array(list(itertools.product(*levels)))
    mids = []
    for d in range(len(lo)):
        others = np.array(list(itertools.product(*levels[:-1])))
        mids.append(np.insert(others, d, 0.5, axis=1))
    unit = np.concatenate([corners, *mids])
    return lo + unit * (hi - lo)


def box_priors() -> dict[str, Uniform]:
    """Uniform priors on Table 4's hard bounds: the density is positive on the closed box."""
    return {
        "E_c": Uniform(10, 100),
        "log10_K_r": Uniform(0, 12),
        "sigma_a": Uniform(0, 5),
        "length": Uniform(0, 10),
    }


@pytest.mark.parametrize("kernel", KERNELS)
def test_log_joint_finite_on_corners_and_edges(kernel: str, c1) -> None:
    model, meas = c1
    assert meas.y.shape == (11, 351)
    problem = Problem(model, meas, kernel=kernel, priors=box_priors())
    points = corners_and_edge_midpoints(problem.hard_bounds)
    assert len(points) == (48 if kernel != "independent" else 20)
    values = problem.log_joint(points)
    assert np.isfinite(values).all(), points[~np.isfinite(values)]
    assert problem.n_model_evaluations == 8  # 4 corners + 4 edge midpoints of the physical box


@pytest.mark.parametrize("kernel", ["independent", "matern32"])
def test_log_joint_minus_inf_just_outside(kernel: str, c1) -> None:
    model, meas = c1
    problem = Problem(model, meas, kernel=kernel, priors=box_priors())
    lo, hi = problem.hard_bounds.T
    centre = (lo + hi) / 2
    outside = []
    for d in range(len(lo)):
        for value in (lo[d] - 1e-9 * (hi[d] - lo[d]), hi[d] * (1 + 1e-12), np.nan, np.inf, -np.inf):
            point = centre.copy()
            point[d] = value
            outside.append(point)
    values = problem.log_joint(np.array(outside))
    assert (values == -np.inf).all()
    assert problem.n_model_evaluations == 0


@pytest.mark.parametrize("kernel", ["independent", "matern32"])
def test_paper_priors_vanish_only_where_the_gamma_densities_do(kernel: str, c1) -> None:
    """Gamma(2, 2) and Gamma(3, 1) have zero density at 0: -inf there, finite elsewhere, no NaN."""
    problem = Problem(*c1, kernel=kernel, priors=paper_priors())
    points = corners_and_edge_midpoints(problem.hard_bounds)
    values = problem.log_joint(points)
    zero_density = (points[:, 2:] == 0).any(axis=1)
    assert not np.isnan(values).any()
    assert (values[zero_density] == -np.inf).all()
    assert np.isfinite(values[~zero_density]).all()


def test_log_likelihood_finite_at_c1_extremes(c1) -> None:
    """All 11 x 351 = 3,861 points, every kernel, l in {0, 1e-12, 10}, sigma_a in {0, 1e-12, 5}."""
    model, meas = c1
    eta = model(torch.tensor([10.0, 0.0]))[:11]  # the largest strains
    grid = torch.tensor(list(itertools.product([0.0, 1e-12, 5.0], [0.0, 1e-12, 10.0])))
    for kernel in KERNELS:
        values = log_likelihood(meas.y, eta, meas.x, kernel, grid[:, 0], grid[:, 1])
        assert values.shape == (9,) and torch.isfinite(values).all(), kernel
