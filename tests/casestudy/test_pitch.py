"""Bridge 705 at any sensor pitch: the element's own interpolation, default model unchanged."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.casestudy import bridge705
from torchshm.casestudy.frame import bottom_strain, solve
from torchshm.casestudy.truth import TruthConfig, gauge_average, gauge_weights, spread_loads, truth_mesh


def test_default_pitch_is_the_unchanged_model() -> None:
    assert bridge705(pitch=0.1).identity == bridge705().identity
    assert bridge705().x.numel() == 351


def test_dense_pitch_agrees_at_the_coarse_points_and_between_them() -> None:
    coarse, dense = bridge705(), bridge705(pitch=0.025)
    assert dense.x.numel() == 1401 and dense.identity != coarse.identity
    theta = torch.tensor([[35.0, 11.0], [30.0, 9.0]], dtype=torch.float64)
    a, b = coarse(theta), dense(theta)
    torch.testing.assert_close(b[..., ::4], a, rtol=0.0, atol=1e-9)
    # between nodes the strain is linear in each element (moment linear, uniform section),
    # except in the intervals split by a pier node
    midpoint = 0.5 * (a[..., :-1] + a[..., 1:])
    x = coarse.x.numpy()
    piers = coarse.config.pier_x()
    whole = ~((x[:-1, None] < piers) & (x[1:, None] > piers)).any(1)
    assert whole.sum() == whole.size - 2
    torch.testing.assert_close(b[..., 2::4][..., whole], midpoint[..., whole], rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("pitch", [0.0, -0.1, float("nan"), "0.1"])
def test_bad_pitch_is_one_line(pitch: object) -> None:
    with pytest.raises(ValueError, match="^bridge705: pitch must be a positive number"):
        bridge705(pitch=pitch)  # type: ignore[arg-type]


@pytest.mark.slow
def test_gauge_average_at_node_aligned_gauges_equals_the_node_weights() -> None:
    """The any-pitch gauge integral equals the shipped (node-aligned) weighting."""
    config = TruthConfig()
    mesh, c_b = truth_mesh(config)
    F = torch.stack(
        [spread_loads(mesh, config.model.truck, f, config.model.length, config.load_spread) for f in config.model.loads[:2]],
        dim=1,
    )
    U = solve(mesh.frame, F)
    x = config.model.sensor_x()[::50]
    general = gauge_average(mesh, U, c_b, x, config.gauge_length)

    n_el = mesh.deck_x.size - 1
    mid = bottom_strain(mesh.frame, U, torch.arange(n_el), torch.full((n_el,), 0.5), torch.as_tensor(c_b))
    W = torch.as_tensor(gauge_weights(mesh.deck_x, x, config.gauge_length))
    np.testing.assert_allclose(general.numpy(), (W @ mid).numpy(), rtol=1e-8, atol=1e-16)
