"""Input and output transforms of the surrogate."""

from __future__ import annotations

import pytest
import torch

from torchshm.casestudy import Bridge705
from torchshm.surrogate import ResponseTransform
from torchshm.surrogate.transforms import PLAIN

#: the elastic structure of a frame (modulus in column 0, log10 spring stiffness in column 1)
ELASTIC = Bridge705.surrogate_transform


def _design() -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(0)
    theta = torch.stack([10 + 90 * torch.rand(15, generator=g, dtype=torch.float64),
                         12 * torch.rand(15, generator=g, dtype=torch.float64)], dim=-1)
    outputs = torch.randn(15, 6, generator=g, dtype=torch.float64) / theta[:, :1]
    return theta, outputs


def test_elastic_inputs_are_log_modulus_and_log_stiffness_ratio_in_the_unit_box() -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs, **ELASTIC)
    raw = transform.raw_inputs(theta)
    torch.testing.assert_close(raw[:, 0], torch.log10(theta[:, 0]))
    torch.testing.assert_close(raw[:, 1], theta[:, 1] - torch.log10(theta[:, 0]))
    inputs = transform.inputs(theta)
    torch.testing.assert_close(inputs.amin(0), torch.zeros(2, dtype=torch.float64))
    torch.testing.assert_close(inputs.amax(0), torch.ones(2, dtype=torch.float64))


@pytest.mark.parametrize("options", [
    ELASTIC, {**ELASTIC, "standardize": "global"}, {}, PLAIN,
])
def test_targets_are_standardised_and_invert_to_strains(options) -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs, **options)
    targets = transform.targets(theta, outputs)
    torch.testing.assert_close(targets.mean(0), torch.zeros(6, dtype=torch.float64))
    if options.get("standardize", "output") == "output":
        torch.testing.assert_close(targets.std(0), torch.ones(6, dtype=torch.float64))
    torch.testing.assert_close(transform.strains(theta, targets), outputs)


def test_variance_scales_with_the_square_of_the_compliance() -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs, **ELASTIC)
    var = transform.strain_variance(theta, torch.ones(15, 1, dtype=torch.float64))
    torch.testing.assert_close(var, (transform.scale / theta[:, :1]) ** 2)


def test_state_round_trip() -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs, **ELASTIC)
    again = ResponseTransform.from_state(transform.state())
    torch.testing.assert_close(again.inputs(theta), transform.inputs(theta))
    torch.testing.assert_close(again.targets(theta, outputs), transform.targets(theta, outputs))


@pytest.mark.parametrize(("options", "message"), [
    ({"log_inputs": (2,)}, "out of range"),
    ({"modulus": None}, "needs a modulus"),
    ({"relative_to_modulus": (0,)}, "relative to itself"),
    ({"standardize": "minmax"}, "standardize"),
])
def test_bad_options_are_refused(options, message) -> None:
    theta, outputs = _design()
    with pytest.raises(ValueError, match=message):
        ResponseTransform.fit(theta, outputs, **{**ELASTIC, **options})


def test_default_is_plain_scaling() -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs)
    assert transform.options() == PLAIN
    torch.testing.assert_close(transform.raw_inputs(theta), theta)
    torch.testing.assert_close(transform.factor(theta), torch.ones(15, 1, dtype=torch.float64))


def test_non_positive_modulus_is_refused() -> None:
    theta, outputs = _design()
    transform = ResponseTransform.fit(theta, outputs, **ELASTIC)
    with pytest.raises(ValueError, match="positive"):
        transform.inputs(torch.tensor([[-1.0, 3.0]], dtype=torch.float64))
