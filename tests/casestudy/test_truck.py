"""Truck T1 and its axle loads; axles off the deck carry nothing."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from torchshm.casestudy import Bridge705Config, T1, T1_POSITIONS, Truck, bridge705
from torchshm.casestudy.model import bridge_mesh, load_matrix
from torchshm.casestudy.truck import GRAVITY


def test_t1_mass_positions_and_direction() -> None:
    assert T1.total_mass == pytest.approx(34.95)
    assert len(T1_POSITIONS) == 12
    positions, forces = T1.axles(39.8)
    np.testing.assert_allclose(positions, [39.8, 37.9, 34.7, 33.3])
    assert forces.sum() == pytest.approx(34.95 * 1000 * GRAVITY)


def test_axles_beyond_the_abutments_are_dropped() -> None:
    positions, forces = T1.on_deck(3.0, 102.0)
    np.testing.assert_allclose(positions, [3.0, 1.1])
    np.testing.assert_allclose(forces, [7.5e3 * GRAVITY, 7.5e3 * GRAVITY])
    assert T1.on_deck(108.4, 102.0)[0].tolist() == [101.9]
    assert T1.on_deck(-0.5, 102.0)[0].size == 0


def test_load_matrix_carries_only_the_axles_on_the_deck() -> None:
    config = dataclasses.replace(Bridge705Config(), loads=(3.0, 50.0, 108.4))
    mesh = bridge_mesh(config)
    vertical = load_matrix(mesh, config)[1::3]  # w components
    total = -vertical.sum(dim=0)
    expected = [15.0, 34.95, 9.975]
    np.testing.assert_allclose(total.numpy(), np.array(expected) * 1000 * GRAVITY, rtol=1e-12)


def test_model_with_axles_off_the_deck() -> None:
    config = dataclasses.replace(Bridge705Config(), loads=(3.0, -1.0, 108.4))
    mesh = bridge_mesh(config)
    front_only = dataclasses.replace(config, loads=(3.0,), truck=Truck((7.5, 7.5), (0.0, 1.9)))
    torch.testing.assert_close(load_matrix(mesh, config)[:, :1], load_matrix(mesh, front_only), rtol=0, atol=0)
    strains = bridge705(config)(torch.tensor([35.0, 11.5]))
    assert strains[0].abs().max() > 0.1  # two axles on the deck
    assert torch.count_nonzero(strains[1]) == 0  # the whole truck before the left abutment
    assert strains[2].abs().max() > 0.01  # only the rear axle on the deck


def test_truck_rejects_mismatched_axles() -> None:
    with pytest.raises(ValueError, match="same length"):
        Truck((1.0, 2.0), (0.0,))
