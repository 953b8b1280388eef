"""method="emulator" on every campaign shape: sensor lines, dropouts, interpolated positions,
2-D fields, inferred noise levels, one-sided priors.

Where the emulator reproduces the model (a linear model, which its GP fits to rounding error
from a handful of runs), its log joint must be the problem's own log joint: the emulator sees
the data only through the problem's view of them (``at_measured``, ``blocks``, ``noise_of``).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

import torchshm
from torchshm import Gamma, Measurements, Normal, Problem, Uniform
from torchshm.inference.adaptive.field import FieldEmulator
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint
from torchshm.inference.adaptive.runs import measured


class LinearField:
    """``eta = sum_j theta_p[j] * basis[j]`` at `n` points of 1-D positions, two lines, or a
    2-D grid (``kind``); 3 load cases."""

    names = ["p0", "p1"]

    def __init__(self, kind: str = "line") -> None:
        self.loads = torch.tensor([10.0, 20.0, 30.0], dtype=torch.float64)
        if kind == "grid":
            g = torch.linspace(0.0, 1.0, 8, dtype=torch.float64)
            self.x = torch.cartesian_prod(g, g)  # 64 x 2
            s = self.x.sum(-1)
        else:
            self.x = torch.arange(40, dtype=torch.float64) * 0.1
            s = self.x
            if kind == "lines":
                self.x = torch.cat([self.x, self.x])
                self.line = ["bottom"] * 40 + ["top"] * 40
                s = torch.cat([s, 0.5 * s + 1.0])
        self.basis = torch.stack([
            torch.stack([torch.sin((j + 1) * s + 0.4 * k) + 0.2 * k for k in range(3)])
            for j in range(2)
        ])  # 2 x L x n

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        return torch.einsum("...p,pln->...ln", torch.as_tensor(theta_p, dtype=torch.float64), self.basis)


def campaign(kind: str, seed: int = 0) -> tuple[LinearField, Measurements, dict]:
    model = LinearField("grid" if kind == "grid" else "lines" if kind == "lines" else "line")
    rng = np.random.default_rng(seed)
    y = model(torch.tensor([1.2, -0.6])).numpy() + 0.3 * rng.standard_normal((3, model.x.shape[0]))
    x = model.x.numpy()
    options: dict = {}
    if kind == "lines":  # 5 % dropouts and a gap of 0.4 m per load case
        y[rng.random(y.shape) < 0.05] = np.nan
        y[0, 10:14] = np.nan
        y[2, 55:59] = np.nan
        meas = Measurements(x, y, model.loads.numpy(), sigma_e=0.1, line=model.line, missing="mask")
    elif kind == "interpolate":  # readings between the model's nodes
        keep = np.arange(1, 38, 2)
        xm = x[keep] + 0.03
        ym = np.stack([np.interp(xm, x, row) for row in y])
        meas = Measurements(xm, ym, model.loads.numpy(), sigma_e=0.1)
        options["match"] = "interpolate"
    else:
        meas = Measurements(x, y, model.loads.numpy(), sigma_e=0.1)
    return model, meas, options


def problem_of(kind: str, **kwargs: object) -> Problem:
    model, meas, options = campaign(kind)
    priors = {"p0": Normal(0.0, 2.0), "p1": Normal(0.0, 2.0),
              "sigma_a": Gamma(2.0, 2.0), "length": Gamma(3.0, 1.0)}
    kernel = "matern32" if kind != "independent" else "independent"
    if kind == "per_line":
        model, meas, options = campaign("lines")
        options["discrepancy"] = "per_line"
    options.update(kwargs)
    return Problem(model, meas, kernel=kernel, priors=priors, **options)


def exact_emulator(problem: Problem) -> FieldEmulator:
    """An emulator of the linear stand-in model from six runs, exact to 0.05 nats. The kernel
    is the unwarped one: the warp's concentrations, fitted to six runs, bend a linear response
    (1.7 nats off at a log joint of -3,595 with the default ``matern52_additive_warped``)."""
    theta = np.array([[1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [-1.0, -1.0], [0.0, 0.0], [2.0, 0.5]])
    outputs = measured(problem, np.asarray(problem.model_outputs(theta)))
    return FieldEmulator.fit(theta, outputs, torch.arange(problem.y.shape[1], dtype=torch.float64),
                             torch.as_tensor(problem.measurements.loads), kernel="matern52_additive")


@pytest.mark.parametrize("kind", ["line", "lines", "per_line", "interpolate", "grid"])
def test_emulated_log_joint_is_the_problems_on_every_campaign(kind: str) -> None:
    problem = problem_of(kind)
    log_joint = EmulatedLogJoint(problem, exact_emulator(problem))
    rng = np.random.default_rng(1)
    theta = problem.sample_prior(6, rng)
    theta[:, :2] = rng.uniform(-1.0, 1.5, (6, 2))
    np.testing.assert_allclose(log_joint(theta), problem.log_joint(theta), atol=0.05)


def test_inferred_sigma_m_and_sigma_e_enter_the_emulated_log_joint() -> None:
    problem = problem_of("line", sigma_m=Uniform(0.0, 0.2), sigma_e=Gamma(2.0, 20.0))
    assert problem.names[-2:] == ["sigma_m", "sigma_e"]
    log_joint = EmulatedLogJoint(problem, exact_emulator(problem))
    theta = np.array([[1.1, -0.5, 0.4, 2.0, 0.03, 0.12], [0.7, -0.9, 0.8, 1.0, 0.15, 0.05]])
    np.testing.assert_allclose(log_joint(theta), problem.log_joint(theta), atol=0.05)


def test_an_inferred_noise_level_equals_the_fixed_one_at_its_value() -> None:
    free = problem_of("lines", sigma_m=Uniform(0.0, 0.2), sigma_e=Gamma(2.0, 20.0))
    fixed = problem_of("lines", sigma_m=0.07, sigma_e=0.13)
    theta = np.array([[1.1, -0.5, 0.4, 2.0], [0.7, -0.9, 0.8, 1.0]])
    with_noise = np.column_stack([theta, np.full(2, 0.07), np.full(2, 0.13)])
    np.testing.assert_allclose(free.log_likelihood(with_noise), fixed.log_likelihood(theta), rtol=1e-12)


def test_one_sided_priors_get_a_closed_search_box() -> None:
    problem = problem_of("line")
    box = problem.search_bounds
    assert np.all(np.isfinite(problem.hard_bounds[2:, 0])) and np.all(np.isinf(problem.hard_bounds[2:, 1]))
    assert np.all(np.isfinite(box[2:]))
    # the box leaves out 1e-12 of each prior's mass
    for row, prior in zip(box[2:], (Gamma(2.0, 2.0), Gamma(3.0, 1.0))):
        assert abs(prior._scipy().sf(row[1]) - 1e-12) < 1e-13
    assert np.all(np.isinf(box[:2]))  # Normal priors stay unbounded (PyVBMC takes both)


class DensityOnly:
    """A user prior with only ``log_prob`` and ``hard_bounds``: an exponential on [0, inf)."""

    hard_bounds = (0.0, float("inf"))

    def log_prob(self, x: object) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        return np.where(x >= 0, -2.0 * x + np.log(2.0), -np.inf)


def test_a_prior_with_only_log_prob_gets_a_box_a_plausible_range_and_draws() -> None:
    model, meas, _ = campaign("line")
    priors = {"p0": Normal(0.0, 2.0), "p1": Normal(0.0, 2.0), "sigma_a": DensityOnly(), "length": 1.0}
    problem = Problem(model, meas, kernel="matern32", priors=priors)
    lo, hi = problem.search_bounds[2]
    assert lo == 0.0 and 10.0 < hi < 200.0  # exp(-2 x) has fallen 40 nats by x = 20
    plo, phi = problem.plausible_bounds[2]
    assert 0.0 < plo < phi < hi
    assert np.all(np.isfinite(problem.log_prior(problem.sample_prior(50, 0))))


@pytest.mark.slow
def test_emulator_identifies_a_two_fibre_campaign_with_dropouts() -> None:
    problem = problem_of("lines")
    post = torchshm.identify(problem, "emulator", seed=0, max_model_evaluations=25, n_steps=100,
                             final_steps=150, n_evidence=2000)
    summary = post.summary()
    assert post.n_model_evaluations <= 25
    for name, truth in (("p0", 1.2), ("p1", -0.6)):
        row = summary[name]
        assert abs(row.mean - truth) < 4 * row.sd + 0.05, (name, row)


def test_predictive_draws_use_each_draws_inferred_noise_levels() -> None:
    from torchshm.inference import Posterior

    problem = problem_of("line", sigma_m=Uniform(0.0, 0.5), sigma_e=Gamma(2.0, 20.0))
    design = np.array([[1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [-1.0, -1.0], [0.0, 0.0], [2.0, 0.5]])
    problem.model_outputs(design)  # stored runs for the predictive's emulator
    rng = np.random.default_rng(0)
    spread = {}
    for level in (0.01, 0.4):
        samples = np.column_stack([1.2 + 0.01 * rng.standard_normal(400), -0.6 + 0.01 * rng.standard_normal(400),
                                   np.full(400, 0.01), np.full(400, 1.0), np.full(400, level), np.full(400, 0.05)])
        post = Posterior(names=list(problem.names), method="emcee", samples=samples, problem=problem)
        result = torchshm.posterior_predictive(post, loads=[20.0], n=400, seed=1)
        spread[level] = float(np.mean(np.asarray(result.upper) - np.asarray(result.lower)))
    assert spread[0.4] > 5 * spread[0.01]  # σm = 0.4 of strains ~1 widens the band
