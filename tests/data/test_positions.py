"""The one position matcher."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm.data.positions import POSITION_TOL, match_positions, nearest_index


def test_nearest_index_against_a_brute_force_search(rng: np.random.Generator) -> None:
    available = rng.permutation(np.round(np.linspace(0.0, 10.0, 101), 10))
    wanted = np.concatenate([available[rng.integers(0, 101, 30)] + 0.4 * POSITION_TOL,
                             [0.05, -1.0, 10.5, np.nan]])
    index, found = nearest_index(wanted, available)
    brute = np.abs(wanted[:, None] - available[None, :])
    np.testing.assert_array_equal(found, np.nanmin(np.where(np.isnan(brute), np.inf, brute), 1)
                                  <= POSITION_TOL)
    np.testing.assert_array_equal(index[found], brute[found].argmin(1))
    assert found[:30].all() and not found[30:].any()


def test_match_positions_names_the_missing_values() -> None:
    np.testing.assert_array_equal(match_positions([3.0, 1.0], [1.0, 2.0, 3.0], "load case"),
                                  [2, 0])
    with pytest.raises(ValueError, match="load cases not produced by the model.*: 2.5"):
        match_positions([2.5], [1.0, 2.0, 3.0], "load case")
    with pytest.raises(ValueError, match="produces no positions"):
        match_positions([1.0], [], "position")
