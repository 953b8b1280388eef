"""The posterior and forward-model protocols describe the library's own objects."""

from __future__ import annotations

import numpy as np
import torch

from torchshm.forward import ForwardModel
from torchshm.inference import Posterior
from torchshm.inference.protocol import PosteriorLike


class Line:
    """A minimal forward model: strains ``theta_p[0] * x`` for one load case."""

    x = torch.linspace(0.0, 1.0, 5, dtype=torch.float64)
    loads = torch.tensor([1.0], dtype=torch.float64)

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        return theta_p[..., :1, None] * self.x


def test_posterior_is_posterior_like_and_a_plain_object_is_not() -> None:
    post = Posterior(names=["a"], method="emcee", samples=np.zeros((4, 1)))
    assert isinstance(post, PosteriorLike)
    assert not isinstance(object(), PosteriorLike)


def test_a_model_with_x_loads_and_call_is_a_forward_model() -> None:
    assert isinstance(Line(), ForwardModel)
    assert not isinstance(lambda theta: theta, ForwardModel)
