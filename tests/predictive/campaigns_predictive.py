"""Small campaigns of every kind, with cheap posteriors near the truth, for the predictive tests.

Each campaign is a :class:`~torchshm.Problem` on a few inferred load cases, the held-out
measurements of other load cases, and a :class:`~torchshm.inference.Posterior` made of draws
near the truth (no inference run); the problem keeps the model outputs of a small design
around the truth, as inference would, so the emulator has something to learn from.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import torchshm
from torchshm import Gamma, Measurements, Problem, Uniform
from torchshm.data import with_dropouts
from torchshm.inference import Posterior

ROOT = Path(__file__).resolve().parents[2]
CAMPAIGNS = ("one_fibre", "two_fibres_dropouts", "interpolate", "per_line", "plate")


@dataclass
class Campaign:
    """A problem, its held-out measurements and a posterior near the truth."""

    problem: Problem
    held_out: Measurements
    post: Posterior


def campaign(kind: str, n_design: int = 12, n_samples: int = 400, seed: int = 0) -> Campaign:
    """The campaign ``kind`` (one of :data:`CAMPAIGNS`) with its posterior and stored design."""
    problem, held_out, centre, spread = _problem(kind)
    rng = np.random.default_rng(seed)
    names = problem.names
    mean = np.array([centre[_base(n)] for n in names])
    sd = np.array([spread[_base(n)] for n in names])
    samples = mean + sd * rng.standard_normal((n_samples, len(names)))
    design = mean + 3.0 * sd * rng.standard_normal((n_design, len(names)))
    problem.model_outputs(problem.split.physical(design))  # stored as inference would
    post = Posterior(names=list(names), method="emcee", samples=samples, n_chains=4,
                     priors=dict(problem.priors), problem=problem)
    return Campaign(problem, held_out, post)


def campaign_problem(kind: str, resolution: float | None = None) -> tuple[Problem, Measurements]:
    """The campaign ``kind``'s problem (no model run yet) and its held-out measurements; the
    bridge's fibres read every ``resolution`` m (None: every 0.1 m)."""
    problem, held_out, _, _ = _problem(kind, resolution)
    return problem, held_out


def _base(name: str) -> str:
    return name.split("[")[0]


def _problem(kind: str, resolution: float | None = None) -> tuple[Problem, Measurements, dict, dict]:
    bridge = ({"E_c": 35.0, "log10_K_r": 8.0, "sigma_a": 1.0, "length": 1.5},
              {"E_c": 0.5, "log10_K_r": 0.1, "sigma_a": 0.1, "length": 0.2})
    if kind == "plate":
        if str(ROOT) not in sys.path:
            sys.path.insert(0, str(ROOT))
        from examples.plate_dic.plate import PlateDIC

        data = torchshm.load_measurements(ROOT / "examples/plate_dic/campaign.csv")
        model = PlateDIC(loads=(0.5, 1.0, 1.5))
        priors = {"E": Uniform(10.0, 60.0, plausible=(20.0, 45.0)),
                  "log10_k": Uniform(4.0, 9.0, plausible=(5.0, 8.0)),
                  "sigma_a": Gamma(2.0, 0.5, bounds=(0.0, 20.0), plausible=(1.0, 10.0)),
                  "length": Gamma(3.0, 6.0, bounds=(0.0, 2.0), plausible=(0.1, 1.0))}
        problem = Problem(model, data.select([0.5, 1.5]), priors=priors, sigma_m=0.02)
        return problem, data.select([1.0]), \
            {"E": 32.0, "log10_k": 6.5, "sigma_a": 4.0, "length": 0.3}, \
            {"E": 0.7, "log10_k": 0.08, "sigma_a": 0.4, "length": 0.04}
    lines = 1 if kind in ("one_fibre", "interpolate") else 2
    data = torchshm.synthetic_campaign(0, lines=lines)
    if resolution is not None:
        data = data.downsample(resolution)
    model = torchshm.bridge705(lines=lines)
    if kind == "two_fibres_dropouts":
        data = with_dropouts(data, fraction=0.05, gap=0.4, seed=1)
    if kind == "interpolate":  # readings between the model's positions
        x = data.x[:-1] + 0.04
        y = np.stack([np.interp(x, data.x, row) for row in data.y])
        data = Measurements(x, y, data.loads, sigma_e=data.sigma_e, attrs=data.attrs)
    inferred, held = [float(v) for v in data.loads[[0, 4]]], [float(v) for v in data.loads[[2, 7]]]
    problem = Problem(model, data.select(inferred), kernel="matern32",
                      match="interpolate" if kind == "interpolate" else "exact",
                      discrepancy="per_line" if kind == "per_line" else "shared")
    return problem, data.select(held), *bridge
