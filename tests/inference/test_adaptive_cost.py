"""The emulator method's own compute, estimated before the first model run."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from tests.inference.inference_models import linear_gaussian_problem
from torchshm.inference.adaptive import cost


class Refuses:
    """A forward model that fails the test when run: the estimate needs no model run."""

    def __init__(self, model: object) -> None:
        self.model = model

    def __getattr__(self, name: str) -> object:
        return getattr(self.model, name)

    def __call__(self, *args: object, **kwargs: object) -> object:
        raise AssertionError("the estimate ran the model")


def test_estimate_scales_one_vector_to_a_round_and_the_end() -> None:
    problem = linear_gaussian_problem()
    problem.model = Refuses(problem.model)
    est = cost.estimate(problem, n_walkers=96, n_steps=50, final_steps=50, n_evidence=8000,
                        rng=np.random.default_rng(0))
    assert est.per_vector > 0.0
    assert est.per_round == pytest.approx(cost.ROUND_FACTOR * 96 * 50 * est.per_vector)
    assert est.final == pytest.approx((8000 + 96 * 50) * est.per_vector)
    # a capped run's average: one plug-in pass and N_FIELDS drawn passes over N_POINTS points
    # (a fast likelihood: the draws' budget does not bind)
    from torchshm.inference.adaptive import unsure
    assert est.capped == pytest.approx((1 + unsure.N_FIELDS) * unsure.N_POINTS * est.per_vector)
    # and when that average keeps too few draws, made again on up to MAX_POINTS points
    most = unsure.MAX_POINTS * est.per_vector
    assert est.capped_most == pytest.approx(est.capped + (1 + unsure.fields_for(most)) * most)


def test_announce_warns_only_above_the_limit(caplog: pytest.LogCaptureFixture) -> None:
    problem = linear_gaussian_problem()
    slow = cost.OwnCost(per_vector=0.14, per_round=1.5 * 96 * 50 * 0.14, final=12800 * 0.14)
    with pytest.warns(RuntimeWarning, match=r"17 min of own compute per round.*method='vbmc'"):
        cost.announce(problem, slow)
    quick = cost.OwnCost(per_vector=1.7e-4, per_round=1.2, final=2.2)
    with caplog.at_level(logging.INFO, logger="torchshm.inference.adaptive.method"):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no warning below the limit
            cost.announce(problem, quick)
    assert "1.2 s of own compute per round" in caplog.text
    assert "where that average has to be made again on more points" in caplog.text


@pytest.mark.parametrize("seconds, text", [(12.0, "12 s"), (1020.0, "17 min"), (7560.0, "2.1 h")])
def test_duration(seconds: float, text: str) -> None:
    assert cost.duration(seconds) == text
