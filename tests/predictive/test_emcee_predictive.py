"""The posterior predictive of an emcee posterior, from the outputs the problem kept."""

from __future__ import annotations

import pytest

import torchshm
from predictive_linear_gaussian import TwoShapeModel, make_problem, synthetic_data
from torchshm.predictive import exact_predictive, posterior_predictive
import torchshm.predictive.predictive as pp
from doubles_predictive import linear_setup


def test_long_runs_train_on_a_subset(monkeypatch: pytest.MonkeyPatch) -> None:
    problem, post = linear_setup(n_design=40)
    monkeypatch.setattr(pp, "MAX_TRAINING_POINTS", 25)
    pred = posterior_predictive(post, [20.0], n=50)
    assert pred.n_training == 25


@pytest.mark.filterwarnings("ignore:emcee. the chain after burn-in:RuntimeWarning")
def test_emcee_posterior() -> None:
    """A short chain (its autocorrelation warning is expected): the emulator still applies."""
    model = TwoShapeModel()
    data = synthetic_data(model, seed=1)
    problem = make_problem("matern32", 1.0, data, model)
    post = torchshm.identify(problem, method="emcee", seed=0, n_walkers=8, n_steps=25)
    assert post.log_evidence is None
    model.calls = 0
    pred = posterior_predictive(post, [10.0, 20.0], n=400, seed=0)
    assert model.calls == 0 and pred.n_training == problem.evaluations()[0].shape[0]
    exact = exact_predictive(post, [10.0, 20.0], n=400, seed=0)
    for name in ("mean", "lower", "upper"):
        assert (getattr(pred, name) - getattr(exact, name)).abs().max() < 0.01

    fresh = make_problem("matern32", 1.0, data, model)  # kept no outputs
    with pytest.raises(ValueError, match="no stored model evaluations"):
        posterior_predictive(post, [20.0], n=10, problem=fresh)
