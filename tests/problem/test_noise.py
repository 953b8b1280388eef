"""The noise levels and default priors of a Problem (torchshm.problem.noise)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import torchshm
from torchshm.problem.noise import NoiseLevels
from tests.problem.problem_models import LinearModel


class NoPriors:
    """A model that declares no default priors."""

    names = ("E_c", "log10_K_r")

    def __init__(self) -> None:
        self.inner = LinearModel(np.linspace(0.0, 2.0, 5))
        self.x, self.loads = self.inner.x, self.inner.loads

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        return self.inner(theta_p)


def _data(model: object) -> torchshm.Measurements:
    y = model(torch.tensor([30.0, 5.0])).numpy()  # type: ignore[operator]
    return torchshm.Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.1)  # type: ignore[attr-defined]


def test_priors_none_takes_the_models_own_and_refuses_a_model_without() -> None:
    model = LinearModel(np.linspace(0.0, 2.0, 5))
    assert torchshm.Problem(model, _data(model)).names == ["E_c", "log10_K_r", "sigma_a", "length"]
    bare = NoPriors()
    with pytest.raises(ValueError, match="NoPriors declares no default_priors"):
        torchshm.Problem(bare, _data(bare))
    assert torchshm.Problem(bare, _data(bare), priors=torchshm.paper_priors()).names[0] == "E_c"


def test_noise_levels_fixed_and_inferred() -> None:
    m = _data(LinearModel(np.linspace(0.0, 2.0, 5)))
    given = {"E_c": 1.0, "sigma_e": torchshm.Uniform(0.0, 1.0)}
    levels = NoiseLevels.read(given, 0.05, None, m, [None])
    assert given == {"E_c": 1.0}  # the noise entry is taken out
    assert levels.sigma_m == 0.05 and levels.base == 1.0 and set(levels.priors) == {"sigma_e"}
    fixed = NoiseLevels.read({}, 0.0, None, m, [None])
    assert fixed.sigma_e == fixed.base == 0.1 and fixed.priors == {}
    with pytest.raises(ValueError, match="sigma_m must be finite and >= 0"):
        NoiseLevels.read({}, -1.0, None, m, [None])
    with pytest.raises(ValueError, match="allows negative values"):
        NoiseLevels.read({"sigma_e": torchshm.Uniform(-1.0, 1.0)}, 0.0, None, m, [None])
