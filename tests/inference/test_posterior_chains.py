"""A Posterior's samples must be whole draws of its chains."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm.inference import Posterior


@pytest.mark.parametrize("n_chains", [0, 4, True])
def test_samples_not_a_whole_number_of_chain_draws_are_refused(n_chains) -> None:
    with pytest.raises(ValueError, match="n_chains"):
        Posterior(names=["a"], method="emcee", samples=np.zeros((10, 1)), n_chains=n_chains)


def test_whole_draws_summarise() -> None:
    post = Posterior(names=["a"], method="emcee", samples=np.arange(12.0)[:, None], n_chains=4)
    assert post.summary()["a"].mean == pytest.approx(5.5)
