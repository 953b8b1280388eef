"""``with_dropouts``: random lost readings and one lost stretch per load case, masked."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm import Measurements
from torchshm.data import with_dropouts


@pytest.fixture
def two_lines(rng: np.random.Generator) -> Measurements:
    x = np.round(np.arange(0.0, 10.0, 0.1), 9)
    return Measurements(np.concatenate([x, x]), rng.normal(size=(6, 200)), np.arange(6.0),
                        sigma_e={"a": 0.1, "b": 0.2}, line=["a"] * 100 + ["b"] * 100)


def longest_run(row: np.ndarray) -> int:
    best = run = 0
    for lost in row:
        run = run + 1 if lost else 0
        best = max(best, run)
    return best


def test_random_share_and_one_stretch_per_load_case(two_lines: Measurements) -> None:
    m = with_dropouts(two_lines, fraction=0.05, gap=0.4, seed=4)
    assert m.missing == "mask" and m.sigma_e == two_lines.sigma_e and m.lines == ("a", "b")
    lost = ~m.mask
    assert np.all(lost.sum(axis=1) >= 10) and np.all(lost.sum(axis=1) <= 14)  # 10 at random + <= 4
    for row in lost:  # a 0.4 m stretch at 0.1 m pitch: 4 consecutive readings on one line
        assert max(longest_run(row[:100]), longest_run(row[100:])) >= 4
    np.testing.assert_array_equal(m.y[m.mask], two_lines.y[m.mask])
    assert with_dropouts(two_lines, 0.05, 0.4, seed=4).equals(m)
    assert not with_dropouts(two_lines, 0.05, 0.4, seed=5).equals(m)


def test_no_dropout_keeps_every_reading(two_lines: Measurements) -> None:
    m = with_dropouts(two_lines, fraction=0.0, gap=0.0)
    assert m.n_missing == 0 and np.array_equal(m.y, two_lines.y)


@pytest.mark.parametrize("fraction, gap", [(1.0, 0.4), (-0.1, 0.4), (0.05, -1.0)])
def test_bad_options_are_refused(two_lines: Measurements, fraction: float, gap: float) -> None:
    with pytest.raises(ValueError, match="with_dropouts"):
        with_dropouts(two_lines, fraction, gap)
