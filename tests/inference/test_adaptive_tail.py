"""A pilot of the final importance sampling must lie within the runs' range
(:mod:`torchshm.inference.adaptive.tail`)."""

from __future__ import annotations

import numpy as np
import pytest
from plateau_target import plateau

from torchshm.inference.adaptive.final import extrapolation_run
from torchshm.inference.adaptive.tail import TAIL_MOVE, unseen_tail

HARD = np.array([[-np.inf, np.inf], [-10.0, 10.0]])
PLAUSIBLE = np.array([[-3.0, 3.0], [-9.0, 9.0]])


def test_a_plateau_past_the_runs_holds_the_stop_and_sends_a_run_out() -> None:
    """Runs over y in [-1, 1] only: the plateau's 3 % lies past them and widens y's sd from 0.3
    to about 0.95 (a move of 2.2 sds); the run goes to the pilot's farthest draw. Runs that
    reach y = 9 leave nothing beyond: the move is 0."""
    rng = np.random.default_rng(7)
    chain = np.column_stack([rng.normal(0.0, 1.0, 4000), rng.normal(0.0, 0.3, 4000)])  # the bump
    short = np.linspace(-1.0, 1.0, 9)[:, None]
    draws, beyond, move = unseen_tail(plateau, chain, [1], short, HARD, PLAUSIBLE, seed=0, n=4000)
    assert move > TAIL_MOVE and move == pytest.approx(2.2, rel=0.3)
    assert np.mean(beyond) == pytest.approx(0.03, abs=0.012) and (draws[beyond, 1] > 1.9).all()
    run = extrapolation_run(draws, beyond, [1], short, HARD)
    assert run[0, 1] == pytest.approx(draws[beyond, 1].max())
    wide = np.linspace(-1.0, 9.0, 11)[:, None]
    assert unseen_tail(plateau, chain, [1], wide, HARD, PLAUSIBLE, seed=0, n=4000)[2] == 0.0
