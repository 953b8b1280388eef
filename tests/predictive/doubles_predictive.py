"""Test doubles for the predictive tests: a linear forward model, a problem and a Gaussian posterior."""

from __future__ import annotations

import numpy as np
import torch
from scipy import stats

from torchshm.data import Measurements
from torchshm.kernels import get_kernel
from torchshm.likelihood.blocks import make_blocks
from torchshm.problem import ParameterSplit
from torchshm.problem.matching import match_measured


class LinearModel:
    """``eta = theta_p[0] * a(load, x) + theta_p[1] * b(load, x)`` [µε], counting its calls."""

    def __init__(self, n: int = 40, loads: tuple[float, ...] = (10.0, 20.0, 30.0)) -> None:
        self.x = torch.linspace(0.0, 8.0, n, dtype=torch.float64)
        self.loads = torch.tensor(loads, dtype=torch.float64)
        shift = self.loads[:, None] / 10.0
        self.a = torch.sin(self.x[None, :] / 2.0 + shift)  # L x n
        self.b = torch.cos(self.x[None, :] / 3.0 - shift)
        self.calls = 0

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        self.calls += 1
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        return theta_p[..., 0, None, None] * self.a + theta_p[..., 1, None, None] * self.b


class NormalPrior:
    """Univariate normal prior with ``log_prob`` on tensors."""

    def __init__(self, mean: float, sd: float) -> None:
        self.mean, self.sd = mean, sd

    def log_prob(self, value: torch.Tensor) -> torch.Tensor:
        return torch.distributions.Normal(self.mean, self.sd).log_prob(value)


class FakeProblem:
    """The parts of ``torchshm.Problem`` that the predictive functions read."""

    def __init__(self, model: LinearModel, measurements: Measurements, kernel: str = "matern32",
                 sigma_m: float = 0.05, fixed: dict[str, float] | None = None) -> None:
        self.model = model
        self.measurements = measurements
        self.kernel = kernel
        self.sigma_m = sigma_m
        self.sigma_e = measurements.sigma_e
        self.positions = match_measured(measurements, model)
        self.blocks = make_blocks(measurements.x, measurements.mask, measurements.line_slices(), self.sigma_e)
        self.physical_names = ["a", "b"]
        self.priors: dict[str, object] = {"a": NormalPrior(10.0, 3.0), "b": NormalPrior(5.0, 2.0),
                                          "sigma_a": NormalPrior(1.0, 0.5), "length": NormalPrior(2.0, 1.0)}
        self.priors.update(fixed or {})
        if kernel == "independent":
            self.priors.pop("length", None)
        self.names = [k for k, v in self.priors.items() if not isinstance(v, float)]
        self._theta: list[np.ndarray] = []
        self._outputs: list[np.ndarray] = []

    @property
    def split(self) -> ParameterSplit:
        """The parameter split of the current priors (tests change them after construction)."""
        return ParameterSplit.from_priors(
            self.priors, self.physical_names, get_kernel(self.kernel).has_length
        )

    def model_outputs(self, theta_p: np.ndarray) -> torch.Tensor:
        out = self.model(torch.as_tensor(theta_p))
        self._theta.append(np.atleast_2d(np.asarray(theta_p, dtype=float)))
        self._outputs.append(out.reshape(-1, *out.shape[-2:]).numpy())
        return out

    def evaluations(self) -> tuple[np.ndarray, np.ndarray]:
        if not self._theta:
            n = self.model.x.numel()
            return np.zeros((0, 2)), np.zeros((0, self.model.loads.numel(), n))
        return np.concatenate(self._theta), np.concatenate(self._outputs)


class GaussianPosterior:
    """A multivariate normal posterior with the ``Posterior`` attributes the functions read."""

    def __init__(self, names: list[str], mean: np.ndarray, cov: np.ndarray, problem: object = None,
                 priors: dict | None = None, log_evidence: float | None = None,
                 log_evidence_sd: float | None = None) -> None:
        self.names = list(names)
        self.method = "vbmc"
        self.mean, self.cov = np.asarray(mean, float), np.asarray(cov, float)
        self.problem = problem
        self.priors = priors if priors is not None else getattr(problem, "priors", None)
        self.log_evidence, self.log_evidence_sd = log_evidence, log_evidence_sd
        self._dist = stats.multivariate_normal(self.mean, self.cov)

    def sample(self, n: int, rng: np.random.Generator | None = None) -> np.ndarray:
        rng = rng if rng is not None else np.random.default_rng()
        return rng.multivariate_normal(self.mean, self.cov, size=n)

    def log_pdf(self, theta: np.ndarray) -> np.ndarray:
        return np.atleast_1d(self._dist.logpdf(theta))


def linear_setup(kernel: str = "matern32", n_design: int = 30, seed: int = 0,
                 design_sd: float = 3.0) -> tuple[FakeProblem, GaussianPosterior]:
    """A linear problem with measurements at load 10, a design stored as 'inference' would."""
    rng = np.random.default_rng(seed)
    model = LinearModel()
    truth = torch.tensor([10.0, 5.0])
    y = model(truth)[:1] + 0.3 * torch.randn(1, model.x.numel(), generator=torch.Generator().manual_seed(seed))
    data = Measurements(model.x.numpy()[::2], y.numpy()[:, ::2], [10.0], sigma_e=0.1)
    problem = FakeProblem(model, data, kernel=kernel)
    mean = np.array([10.0, 5.0, 0.8, 1.5])[: len(problem.names)]
    cov = np.diag([0.5, 0.3, 0.01, 0.04])[: len(problem.names), : len(problem.names)]
    post = GaussianPosterior(problem.names, mean, cov, problem)
    design = rng.multivariate_normal(mean[:2], design_sd**2 * cov[:2, :2], size=n_design)
    problem.model_outputs(design)
    return problem, post
