"""User-defined forward models and problems with known answers, for the inference tests.

``LinearModel``: strains linear in the physical parameters, ``eta = A theta_p``, so that with
Normal priors, the ``independent`` kernel with a fixed ``sigma_a`` and ``sigma_m = 0`` the
posterior is Gaussian and the evidence is known in closed form (:func:`linear_gaussian_answer`).

``SlowCountingModel`` sleeps per call and appends one line per evaluated θp to a counter file,
so that a test can count model calls across processes (killed ones included).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from torchshm import Measurements, Normal, Problem


class LinearModel:
    """``eta[l, i] = sum_j theta_p[j] * basis[j, l, i]`` for `L` loads at `n` positions.

    Args:
        n: number of positions (0.1 m pitch from 0).
        loads: front-axle positions [m] of the load cases.
        n_params: number of physical parameters `P`.
    """

    def __init__(self, n: int = 60, loads: tuple[float, ...] = (10.0, 20.0), n_params: int = 2) -> None:
        self.x = torch.arange(n, dtype=torch.float64) * 0.1
        self.loads = torch.tensor(loads, dtype=torch.float64)
        span = float(self.x[-1]) + 0.1
        shapes = []
        for j in range(n_params):
            per_load = [
                torch.sin((j + 1) * torch.pi * self.x / span + 0.3 * k) * (1.0 + 0.2 * k)
                + 0.1 * j * self.x / span
                for k in range(len(loads))
            ]
            shapes.append(torch.stack(per_load))
        self.basis = torch.stack(shapes)  # P x L x n
        self.names = [f"p{j}" for j in range(n_params)]

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        return torch.einsum("...p,pln->...ln", theta_p, self.basis)


class SlowCountingModel(LinearModel):
    """A :class:`LinearModel` that sleeps ``delay`` s per θp and logs each θp to ``counter``."""

    def __init__(self, counter: str | Path, delay: float = 0.05, **kwargs: object) -> None:
        super().__init__(**kwargs)  # type: ignore[arg-type]
        self.counter = str(counter)
        self.delay = float(delay)
        self.identity = "slow-linear-model-v1"

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        flat = theta_p.reshape(-1, theta_p.shape[-1])
        for row in flat:
            time.sleep(self.delay)
            with open(self.counter, "a", encoding="utf-8") as fh:
                fh.write(" ".join(f"{v:.17g}" for v in row.tolist()) + "\n")
        return super().__call__(theta_p)


class BeamModel:
    """Strains [µε] of a beam on rotational end springs under a point load (a cheap stand-in
    for the bridge model, same parameters and the same 0.1 m pitch).

    The span runs from 35 m to 70 m. For a load at ``a`` the simply supported moment is
    reduced by the end moments ``r M_fixed`` with ``r = rho / (rho + 2)`` and spring ratio
    ``rho = 10**((log10_K_r - 9) / decades) * 30 / E_c``; the strain is the moment over
    ``E_c``. With ``decades = 1`` the springs go from pinned to fixed within about 7 <
    log10_K_r < 11, leaving a flat plateau below (a trap for any local search); with
    ``decades = 4`` the transition spans the whole prior range.
    """

    names = ["E_c", "log10_K_r"]

    def __init__(
        self, loads: tuple[float, ...] = tuple(38.0 + 3.0 * k for k in range(11)), decades: float = 4.0
    ) -> None:
        self.x = torch.round(torch.arange(351, dtype=torch.float64) + 350.0) / 10.0
        self.loads = torch.tensor(loads, dtype=torch.float64)
        self.decades = float(decades)
        self.identity = f"beam-model-v1-{decades:g}"

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        e_c, log_k = theta_p[..., 0, None, None], theta_p[..., 1, None, None]
        span = 35.0
        s = (self.x - 35.0)[None, :]
        a = (self.loads - 35.0)[:, None].clamp(0.5, span - 0.5)
        simple = torch.where(s <= a, s * (span - a) / span, a * (span - s) / span)
        fixed = a * (span - a) / span * 0.5  # uniform end-moment shape, a stand-in
        rho = 10.0 ** ((log_k - 9.0) / self.decades) * 30.0 / e_c
        r = rho / (rho + 2.0)
        return 1000.0 * (simple - r * fixed) / e_c


def beam_problem(
    truth: tuple[float, float, float, float] = (33.4, 6.0, 0.9, 2.0), seed: int = 5,
    kernel: str = "matern32", store: object = None, decades: float = 4.0,
) -> Problem:
    """Paper-style 4-parameter problem (E_c, log10_K_r, sigma_a, length) on 11 load cases x 351
    positions = 3,861 synthetic strains from :class:`BeamModel` plus a Matern-3/2 discrepancy.

    With the defaults the posterior is unimodal (a profile of the log joint over a 9 x 11 grid
    of E_c and log10_K_r has one maximum) and about 1e-3 of the plausible box wide; with
    ``decades=1`` and ``log10_K_r = 9`` a second, pinned-spring mode appears at low
    ``log10_K_r``.
    """
    from torchshm import paper_priors
    from torchshm.kernels import get_kernel

    model = BeamModel(decades=decades)
    rng = np.random.default_rng(seed)
    eta = model(torch.tensor(truth[:2])).numpy()
    cov = get_kernel(kernel)(model.x, sigma_a=torch.tensor(truth[2]), length=torch.tensor(truth[3]))
    chol = np.linalg.cholesky(cov.numpy().reshape(351, 351) + 1e-9 * np.eye(351))
    delta = (chol @ rng.standard_normal((351, eta.shape[0]))).T
    y = eta * (1 + 0.05 * rng.standard_normal(eta.shape)) + delta + 0.1 * rng.standard_normal(eta.shape)
    meas = Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.1)
    return Problem(model, meas, kernel=kernel, priors=paper_priors(), store=store)


class WaveModel:
    """Strains [µε] ``8 sin((2 + a) x) + 4 b² cos(x)`` at ``n`` points of [0, 3] m, one load:
    a smooth nonlinear field of two parameters ``a``, ``b`` (for the emulator's error tests)."""

    names = ["a", "b"]

    def __init__(self, n: int = 25) -> None:
        self.x = torch.linspace(0.0, 3.0, n, dtype=torch.float64)
        self.loads = torch.tensor([0.0], dtype=torch.float64)

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        t = torch.as_tensor(theta_p, dtype=torch.float64)
        a, b = t[..., 0, None, None], t[..., 1, None, None]
        return 8.0 * torch.sin((2.0 + a) * self.x) + 4.0 * b**2 * torch.cos(self.x)


def linear_gaussian_problem(
    truth: tuple[float, ...] = (1.3, -0.7), prior_sd: float = 1.0, sigma_a: float = 0.3,
    sigma_e: float = 0.1, seed: int = 3, model: LinearModel | None = None, store: object = None,
) -> Problem:
    """A :class:`~torchshm.Problem` whose posterior is Gaussian (see the module docstring)."""
    model = model or LinearModel(n_params=len(truth))
    rng = np.random.default_rng(seed)
    eta = np.einsum("p,pln->ln", np.asarray(truth, dtype=np.float64), model.basis.numpy())
    noise = np.sqrt(sigma_a**2 + sigma_e**2)
    y = eta + noise * rng.standard_normal(eta.shape)
    meas = Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=sigma_e)
    priors: dict[str, object] = {name: Normal(0.0, prior_sd) for name in model.names}
    priors["sigma_a"] = sigma_a
    return Problem(model, meas, kernel="independent", priors=priors, sigma_m=0.0, store=store)


def linear_gaussian_answer(problem: Problem) -> tuple[np.ndarray, np.ndarray, float]:
    """Exact posterior mean `D`, covariance `D x D` and log evidence of a linear problem."""
    model = problem.model
    y = np.asarray(problem.measurements.y).ravel()
    A = model.basis.numpy().reshape(model.basis.shape[0], -1).T  # (L n) x P
    m0 = np.array([problem.priors[n].mean for n in problem.names])
    S0 = np.diag([problem.priors[n].sd ** 2 for n in problem.names])
    s2 = float(problem.priors["sigma_a"]) ** 2 + problem.sigma_e**2
    cov = np.linalg.inv(np.linalg.inv(S0) + A.T @ A / s2)
    mean = cov @ (np.linalg.solve(S0, m0) + A.T @ y / s2)
    C = s2 * np.eye(len(y)) + A @ S0 @ A.T
    r = y - A @ m0
    _, logdet = np.linalg.slogdet(C)
    log_evidence = -0.5 * (r @ np.linalg.solve(C, r) + logdet + len(y) * np.log(2 * np.pi))
    return mean, cov, float(log_evidence)
