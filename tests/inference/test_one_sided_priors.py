"""Priors bounded on one side only (``Gamma(2.0, 2.0)`` without ``bounds``, as docs/api.md
writes them) work with every method: VBMC and the emulator search the box closed at the
priors' 1 - 1e-12 quantiles; emcee needs no box."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import torchshm
from test_emulator_campaigns import problem_of

pytestmark = pytest.mark.slow

OPTIONS = {
    "vbmc": {"max_fun_evals": 60, "display": "off", "n_samples": 2000},
    "emcee": {"n_walkers": 16, "n_steps": 400, "burn": 200},
    "emulator": {"n_steps": 100, "final_steps": 150, "n_evidence": 2000, "max_model_evaluations": 30},
}


@pytest.mark.parametrize("method", ["vbmc", "emcee", "emulator"])
def test_unbounded_gamma_priors_on_sigma_a_and_length(method: str) -> None:
    problem = problem_of("line")
    assert np.isinf(problem.hard_bounds[2:, 1]).all()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = torchshm.identify(problem, method, seed=0, **OPTIONS[method])
    summary = post.summary()
    for name, truth in (("p0", 1.2), ("p1", -0.6)):
        row = summary[name]
        assert abs(row.mean - truth) < 4 * row.sd + 0.05, (method, name, row)
    assert np.all(post.samples[:, 2:] > 0)
