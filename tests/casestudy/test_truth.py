"""The truth structure behind the synthetic campaign."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from torchshm.casestudy import T1, bridge705
from torchshm.casestudy.model import bridge_mesh
from torchshm.casestudy.truth import Crack, TruthConfig, deck_sections, gauge_weights, spread_loads, truth_strains

#: the truth with every refinement switched off, meshed finer than the model over 45–55 m
PLAIN = TruthConfig(
    fine_pitch=0.05, fine_start=45.0, fine_end=55.0, haunch_depth=0.0, pier_flare=0.0, zones=(), cracks=(),
    gauge_length=0.0, load_spread=0.0,
)


def test_plain_truth_equals_the_model_on_a_finer_mesh() -> None:
    model = bridge705(PLAIN.model)
    expected = model(torch.tensor([PLAIN.E_c, PLAIN.log10_K_r]))
    got = truth_strains(PLAIN)
    assert float((got - expected).abs().max() / expected.abs().max()) < 1e-8


def test_cracks_raise_the_local_strain_in_a_sagging_zone() -> None:
    crack = Crack(50.2, 0.4, 0.8, 1.12)
    config = dataclasses.replace(PLAIN, cracks=(crack,))
    model = bridge705(config.model)
    x = model.x.numpy()
    at, far = int(np.argmin(np.abs(x - 50.2))), int(np.argmin(np.abs(x - 52.0)))
    expected = model(torch.tensor([config.E_c, config.log10_K_r]))[6]  # front axle at 55.1
    got = truth_strains(config)[6]
    assert float(got[at] / expected[at]) == pytest.approx(1.12 / 0.8, rel=0.02)
    assert float(got[far] / expected[far]) == pytest.approx(1.0, abs=0.02)


def test_deck_sections_haunches_zones_and_cracks() -> None:
    config = TruthConfig()
    x = np.round(np.arange(0.0, 102.0001, 0.05), 9)
    area, inertia, c_b = deck_sections(config, x)
    mid = 0.5 * (x[1:] + x[:-1])
    deck = config.model.deck
    plain = int(np.argmin(np.abs(mid - 20.0)))  # no haunch, zone or crack at 20 m
    assert inertia[plain] == pytest.approx(deck.inertia) and c_b[plain] == pytest.approx(deck.c_b)
    near_pier = int(np.argmin(np.abs(mid - config.model.pier_x()[1])))
    assert c_b[near_pier] == pytest.approx(500.0 * (deck.depth + config.haunch_depth), rel=0.02)
    assert area[near_pier] > area[plain]
    zone = int(np.argmin(np.abs(mid - 41.2)))  # rail zone, clear of the haunch
    assert inertia[zone] == pytest.approx(config.zones[1].stiffness * deck.inertia)
    crack = int(np.argmin(np.abs(mid - 50.2)))
    assert inertia[crack] < 0.85 * deck.inertia and c_b[crack] > 1.1 * deck.c_b


def test_gauge_weights_average_over_the_gauge() -> None:
    x = np.round(np.arange(0.0, 2.0001, 0.025), 9)
    sensors = np.array([0.5, 1.0, 1.5])
    W = gauge_weights(x, sensors, 0.2)
    np.testing.assert_allclose(W.sum(axis=1), 1.0, atol=1e-12)
    mid = 0.5 * (x[1:] + x[:-1])
    np.testing.assert_allclose(W @ (3.0 * mid + 1.0), 3.0 * sensors + 1.0, atol=1e-12)
    with pytest.raises(ValueError, match="gauge"):
        gauge_weights(np.round(np.arange(0.0, 2.0001, 0.03), 9), sensors, 0.2)


def test_spread_loads_keep_resultant_and_moment() -> None:
    config = TruthConfig().model
    mesh = bridge_mesh(config)
    n = mesh.deck_x.size
    F = spread_loads(mesh, T1, 50.0, config.length, spread=1.0)[1::3].numpy()[:n]  # deck w components
    positions, forces = T1.axles(50.0)
    assert -F.sum() == pytest.approx(forces.sum(), rel=1e-12)
    assert -(F * mesh.deck_x).sum() == pytest.approx((forces * positions).sum(), rel=1e-12)
    assert np.count_nonzero(F) > 4 * 10  # spread over many nodes
    at_end = spread_loads(mesh, T1, 102.2, config.length, spread=1.0)[1::3].numpy()[:n]
    # front axle at 102.2 m: only its print over 101.7–102.0 m (0.3 of 1.0 m) is on the deck
    assert -at_end.sum() == pytest.approx(forces.sum() - 0.7 * forces[0], rel=1e-12)
