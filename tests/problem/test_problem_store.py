"""``Problem`` with an evaluation store: outputs persist and are reused across problems."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from problem_models import LinearModel

from torchshm import Problem
from torchshm.storage import EvaluationStore

THETA = np.array(
    [
        [33.0, 11.5, 0.9, 2.0],
        [33.0, 11.5, 1.2, 0.5],
        [40.0, 10.0, 0.9, 2.0],
        [40.0, 10.0 * (1 + 1e-14), 0.9, 2.0],
    ]
)


def test_store_persists_and_is_reused(small, tmp_path: Path) -> None:
    model, meas = small
    path = tmp_path / "evaluations.sqlite"
    first = Problem(model, meas, store=path)
    values = first.log_joint(THETA)
    assert first.n_model_evaluations == 2 and len(model.calls) == 2
    np.testing.assert_allclose(values, Problem(model, meas).log_joint(THETA), rtol=1e-13)

    again = Problem(model, meas, kernel="exponential", store=EvaluationStore(path))
    model.calls.clear()
    again.log_joint(THETA)
    assert again.n_model_evaluations == 0 and model.calls == []
    theta_p, outputs = again.evaluations()
    np.testing.assert_allclose(theta_p, [[33.0, 11.5], [40.0, 10.0]])
    np.testing.assert_allclose(outputs, model(torch.as_tensor(theta_p)).numpy(), rtol=1e-14)


def test_failed_runs_are_minus_inf_and_not_evaluations(small, tmp_path: Path) -> None:
    model, meas = small
    failing = LinearModel(model.x.numpy(), nan_above=35.0)
    problem = Problem(failing, meas, store=tmp_path / "evaluations.sqlite")
    values = problem.log_joint(THETA)
    assert np.isfinite(values[:2]).all() and (values[2:] == -np.inf).all()
    theta_p, outputs = problem.evaluations()
    assert theta_p.shape == (1, 2) and outputs.shape == (1, 12, 61)


def test_empty_store_has_no_evaluations(small, tmp_path: Path) -> None:
    theta_p, outputs = Problem(*small, store=tmp_path / "e.sqlite").evaluations()
    assert theta_p.shape == (0, 2) and outputs.shape == (0, 12, 61)
