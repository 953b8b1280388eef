"""A torchshm.Problem with a closed-form posterior and evidence, for the predictive tests.

The forward model is linear, ``eta = theta_p[0] * a + theta_p[1] * b``; with Normal priors on
``theta_p``, ``sigma_m = 0`` and fixed ``sigma_a`` and ``length``, Eq. (21) makes the posterior
Gaussian and the evidence a Gaussian density of the data (:func:`analytic`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from scipy import stats

from torchshm import Measurements, Normal, Problem
from torchshm.kernels import get_kernel


class TwoShapeModel:
    """``eta[l, i] = p0 * a[l, i] + p1 * b[l, i]`` [µε] on 0.2 m pitch, counting calls."""

    names = ("p0", "p1")

    def __init__(self, n: int = 40, loads: tuple[float, ...] = (10.0, 20.0)) -> None:
        self.x = torch.arange(n, dtype=torch.float64) * 0.2
        self.loads = torch.tensor(loads, dtype=torch.float64)
        shift = self.loads[:, None] / 10.0
        self.a = torch.sin(self.x[None, :] / 1.5 + shift)
        self.b = torch.cos(self.x[None, :] / 2.5 - shift) + 0.05 * self.x[None, :]
        self.calls = 0

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        self.calls += 1
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        return theta_p[..., 0, None, None] * self.a + theta_p[..., 1, None, None] * self.b


@dataclass
class Answer:
    """Closed-form posterior mean `2`, covariance `2 x 2` and log evidence [nats]."""

    mean: np.ndarray
    cov: np.ndarray
    log_evidence: float


def make_problem(kernel: str, prior_sd: float, data: Measurements, model: TwoShapeModel,
                 sigma_a: float = 0.5, length: float = 1.0) -> Problem:
    """The linear problem with N(1, prior_sd) and N(2, prior_sd) priors on p0, p1."""
    priors = {"p0": Normal(1.0, prior_sd), "p1": Normal(2.0, prior_sd), "sigma_a": sigma_a, "length": length}
    return Problem(model, data, kernel=kernel, priors=priors, sigma_m=0.0)


def analytic(problem: Problem) -> Answer:
    """Exact posterior and evidence of a :func:`make_problem` problem."""
    model, data = problem.model, problem.measurements
    cov = get_kernel(problem.kernel)(data.x, sigma_a=problem.priors["sigma_a"],
                                     length=problem.priors.get("length", 1.0)).numpy()
    cov = cov + problem.sigma_e**2 * np.eye(data.n)
    rows = [model.loads.numpy().tolist().index(v) for v in data.loads]
    cols = [int(np.argmin(np.abs(model.x.numpy() - v))) for v in data.x]
    basis = np.stack([model.a.numpy()[rows][:, cols], model.b.numpy()[rows][:, cols]], -1)  # L x n x 2
    mu0 = np.array([problem.priors["p0"].mean, problem.priors["p1"].mean])
    s0 = np.diag([problem.priors["p0"].sd ** 2, problem.priors["p1"].sd ** 2])
    a = basis.reshape(-1, 2)
    big = np.kron(np.eye(len(rows)), cov)
    y = data.y.reshape(-1)
    log_ev = stats.multivariate_normal(a @ mu0, a @ s0 @ a.T + big).logpdf(y)
    inv = np.linalg.inv(big)
    post_cov = np.linalg.inv(np.linalg.inv(s0) + a.T @ inv @ a)
    post_mean = post_cov @ (np.linalg.solve(s0, mu0) + a.T @ inv @ y)
    return Answer(post_mean, post_cov, float(log_ev))


def synthetic_data(model: TwoShapeModel, seed: int = 0) -> Measurements:
    """Data of load 10 from p = (1.3, 1.8) plus a Matérn 3/2 discrepancy and noise."""
    rng = np.random.default_rng(seed)
    eta = model(torch.tensor([1.3, 1.8]))[:1].numpy()
    k = get_kernel("matern32")(model.x, sigma_a=0.5, length=1.0).numpy() + 0.01 * np.eye(model.x.numel())
    y = eta + (np.linalg.cholesky(k) @ rng.standard_normal(model.x.numel()))[None]
    return Measurements(model.x.numpy(), y, [10.0], sigma_e=0.1)
