"""model_identity and output_shape of the forward-model protocol."""

from __future__ import annotations

import pytest
import torch

from torchshm.forward import ForwardModel, model_identity, output_shape


class _Linear:
    def __init__(self, n: int = 4) -> None:
        self.x = torch.linspace(0.0, 1.0, n)
        self.loads = torch.tensor([9.8, 39.8])

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        return theta_p[..., :1, None] * self.x * self.loads[:, None]


def test_protocol_identity_and_shape() -> None:
    model = _Linear()
    assert isinstance(model, ForwardModel) and output_shape(model) == (2, 4)
    assert model_identity(model) == model_identity(_Linear()) != model_identity(_Linear(5))
    model.identity = "linear-v1"
    assert model_identity(model) == "linear-v1"


def test_output_shape_needs_positions_or_coordinates_and_one_dimensional_loads() -> None:
    model = _Linear()
    model.x = torch.zeros(4, 2)  # (n, d) coordinates of a field
    assert output_shape(model) == (2, 4)
    model.x = torch.zeros(2, 2, 2)
    with pytest.raises(ValueError, match=r"'x' must be \(n,\) positions or \(n, d\) coordinates, got shape \(2, 2, 2\)"):
        output_shape(model)
    model.x, model.loads = torch.zeros(4), torch.zeros(2, 2)
    with pytest.raises(ValueError, match=r"'loads' must be one-dimensional, got shape \(2, 2\)"):
        output_shape(model)
    del model.loads
    with pytest.raises(ValueError, match="has no attribute 'loads'"):
        output_shape(model)
