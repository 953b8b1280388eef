"""Small posterior predictives of every drawing form, and fingerprints of their numbers.

The fingerprints in ``test_chunks.py`` were recorded with the predictive as it was before its
draws were made in chunks of parameter vectors (one array per copy of all draws): the chunked
predictive must give the same numbers for the same seed (float64 round-off).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import torch

import torchshm
from campaigns_predictive import campaign
from doubles_predictive import linear_setup
from torchshm import Gamma, Problem, Uniform
from torchshm.inference import Posterior
from torchshm.predictive import exact_predictive, posterior_predictive


def _line_dense(**kw: Any):
    _, post = linear_setup("matern32")
    return posterior_predictive(post, [20.0, 30.0], n=50, seed=3, include_surrogate_variance=True, **kw)


def _line_diagonal(**kw: Any):
    _, post = linear_setup("independent")
    return posterior_predictive(post, [10.0, 20.0, 30.0], n=37, seed=1, **kw)


def _line_exact(**kw: Any):
    _, post = linear_setup("matern32")
    return exact_predictive(post, [20.0, 30.0], n=33, seed=2, **kw)


def _fibres_state_space(**kw: Any):
    c = campaign("two_fibres_dropouts", n_samples=200)
    return posterior_predictive(c.post, [float(v) for v in c.held_out.loads], n=40, seed=0, **kw)


def _per_line(**kw: Any):
    c = campaign("per_line", n_samples=200)
    return posterior_predictive(c.post, [float(c.held_out.loads[0])], n=35, seed=5, **kw)


def _field_dense(**kw: Any):
    c = campaign("plate", n_samples=200)
    return posterior_predictive(c.post, [1.0], n=24, seed=0, include_surrogate_variance=True, **kw)


def _field_upscaled(**kw: Any):
    c = campaign("plate", n_samples=200)
    p = c.problem
    priors = {k: v for k, v in p.priors.items() if k != "length"}
    priors["length"] = 0.125  # the element side [m], fixed
    problem = Problem(p.model, p.measurements, kernel="upscaled", priors=priors, sigma_m=0.0, sigma_e=0.5)
    theta_p, outputs = p.evaluations()
    problem.model_outputs(theta_p)
    rng = np.random.default_rng(4)
    samples = np.column_stack([32.0 + 0.7 * rng.standard_normal(200), 6.5 + 0.08 * rng.standard_normal(200),
                               4.0 + 0.4 * rng.standard_normal(200)])
    post = Posterior(names=list(problem.names), method="emcee", samples=samples, n_chains=4,
                     priors=dict(problem.priors), problem=problem)
    return posterior_predictive(post, [1.0], n=21, seed=7, **kw)


def _inferred_noise(**kw: Any):
    data = torchshm.synthetic_campaign(0, lines=1).downsample(0.5)
    problem = Problem(torchshm.bridge705(lines=1), data.select([float(data.loads[0])]), kernel="matern32",
                      sigma_m=Uniform(0.0, 0.2), sigma_e=Gamma(2.0, 20.0))
    rng = np.random.default_rng(2)
    centre = {"E_c": 35.0, "log10_K_r": 8.0, "sigma_a": 1.0, "length": 1.5, "sigma_m": 0.05, "sigma_e": 0.1}
    spread = {"E_c": 0.5, "log10_K_r": 0.1, "sigma_a": 0.1, "length": 0.2, "sigma_m": 0.01, "sigma_e": 0.01}
    mean = np.array([centre[n] for n in problem.names])
    sd = np.array([spread[n] for n in problem.names])
    problem.model_outputs(problem.split.physical(mean + 3.0 * sd * rng.standard_normal((12, len(mean)))))
    post = Posterior(names=list(problem.names), method="emcee", samples=mean + sd * rng.standard_normal((200, len(mean))),
                     n_chains=4, priors=dict(problem.priors), problem=problem)
    return posterior_predictive(post, [float(data.loads[3])], n=30, seed=9, **kw)


CASES: dict[str, Callable[..., Any]] = {
    "line_dense": _line_dense, "line_diagonal": _line_diagonal, "line_exact": _line_exact,
    "fibres_state_space": _fibres_state_space, "per_line": _per_line, "field_dense": _field_dense,
    "field_upscaled": _field_upscaled, "inferred_noise": _inferred_noise,
}


def fingerprint(pred: Any) -> list[float]:
    """Sums of the draws, their squares, a weighted sum (the order of the numbers), and of the
    mean, bounds and model responses: equal fingerprints are equal numbers in practice."""
    s = pred.samples.to(torch.float64).reshape(-1)
    w = torch.sin(torch.arange(s.numel(), dtype=torch.float64))
    out = [float(s.sum()), float(s.square().sum()), float((w * s).sum())]
    out += [float(getattr(pred, k).sum()) for k in ("mean", "lower", "upper")]
    if pred.eta is not None:
        out.append(float(pred.eta.sum()))
    return out
