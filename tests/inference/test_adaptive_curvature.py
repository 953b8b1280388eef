"""The exploration's second-order reading (:mod:`torchshm.inference.adaptive.curvature`): its
quadrature against Monte Carlo of the two-normal bound, and the bound against Monte Carlo of an
exactly quadratic log-likelihood."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from torchshm.inference.adaptive.curvature import quadratic_tail

DRAWS = 400_000


def _quadratic(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A slope `n` and a positive semi-definite curvature `n x n` of rank `n - 1` [nats]."""
    a = rng.normal(0.0, 4.0, n)
    b = rng.normal(0.0, 1.0, (n, n - 1))
    return a, b @ b.T


@pytest.mark.parametrize("gap", [-2.0, 3.0, 8.0, 15.0])
def test_the_quadrature_is_the_two_normal_tail_and_bounds_the_quadratic(rng: np.random.Generator,
                                                                       gap: float) -> None:
    """For ``ℓ(z) = aᵀz - ½ zᵀHz`` (6 latent normals): ``quadratic_tail`` equals the Monte Carlo
    chance of ``|a| α - β²/(2c) >= gap`` to 3 Monte Carlo sds (+1e-6), and is at least the
    Monte Carlo chance of ``ℓ(z) >= gap`` less 3 sds; the first-order tail ``Φ(-gap/|a|)`` is
    larger still."""
    a, h_mat = _quadratic(rng, 6)
    u = a / np.linalg.norm(a)
    h = h_mat @ u
    c = float(u @ h)
    got = float(quadratic_tail(np.array([np.linalg.norm(a)]), np.array([c]), np.array([np.linalg.norm(h)]),
                               np.array([gap]))[0])
    z = rng.standard_normal((DRAWS, 6))
    alpha, beta = z @ u, z @ h
    two = np.mean(np.linalg.norm(a) * alpha - beta**2 / (2.0 * c) >= gap)
    exact = np.mean(z @ a - 0.5 * np.einsum("ij,jk,ik->i", z, h_mat, z) >= gap)
    sd = lambda p: np.sqrt(max(p * (1 - p), 1e-12) / DRAWS)  # noqa: E731
    assert abs(got - two) <= 3 * sd(two) + 1e-6
    assert got >= exact - 3 * sd(exact)
    assert norm.sf(gap / np.linalg.norm(a)) >= got - 1e-9


def test_without_curvature_it_is_the_first_order_tail() -> None:
    """c = 0 gives ``Φ(-gap / |a|)``; a gap of -inf or +inf gives 1 or 0."""
    got = quadratic_tail(np.array([2.0, 2.0, 1.0, 1.0]), np.zeros(4), np.ones(4),
                         np.array([1.0, 6.0, -np.inf, np.inf]))
    np.testing.assert_allclose(got[:2], norm.sf(np.array([0.5, 3.0])), rtol=1e-12)
    assert got[2] == 1.0 and got[3] == 0.0


def test_the_chance_at_a_point_bounds_the_exact_draws() -> None:
    """On an emulator of a small model (σm = 0, a squared-exponential discrepancy), at a point far
    from the data: ``reach_chance`` is at least the share of 20,000 exact Eq. (21) log joints at
    joint draws of the emulator's error that reach each of three levels (less 3 Monte Carlo sds),
    and, the curvature being small there, at most 1.5 times that share (+3 sds)."""
    import torch
    from inference_models import WaveModel

    from torchshm import Measurements, Problem, Uniform
    from torchshm.inference.adaptive.curvature import reach_chance
    from torchshm.inference.adaptive.field import FieldEmulator
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

    model = WaveModel(40)
    rng = np.random.default_rng(0)
    y = model(torch.tensor([0.4, 0.6])).numpy() + 0.3 * rng.standard_normal((1, 40))
    priors = {"a": Uniform(0.0, 1.0), "b": Uniform(0.0, 1.0), "sigma_a": 2.0, "length": 1.0}
    problem = Problem(model, Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.1),
                      kernel="squared_exponential", sigma_m=0.0, priors=priors)
    side = np.linspace(0.0, 1.0, 4)
    theta = np.stack(np.meshgrid(side, side), -1).reshape(-1, 2)
    emulator = FieldEmulator.fit(theta, np.asarray(problem.model_outputs(theta)), model.x, model.loads)
    log_joint = EmulatedLogJoint(problem, emulator)
    row = np.array([[0.85, 0.15]])
    mean, var, rows = log_joint.parts(row)
    z = torch.randn((20_000, emulator.error_basis.shape[1]), dtype=mean.dtype,
                    generator=torch.Generator().manual_seed(1))
    fields = mean + var.sqrt() * (z @ emulator.error_basis.mT).reshape(20_000, *mean.shape[1:])
    prior = float(np.asarray(problem.log_prior(row)).reshape(-1)[0])
    draws = log_joint.at(fields, None, rows.expand(20_000, -1)) + prior
    for q in (0.9, 0.99, 0.999):
        level = float(np.quantile(draws, q))
        exact = float(np.mean(draws >= level))
        got = float(reach_chance(log_joint, row, level)[0])
        sd = np.sqrt(exact * (1 - exact) / draws.size)
        assert exact - 3 * sd <= got <= 1.5 * exact + 3 * sd
