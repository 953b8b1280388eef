"""The mode search that precedes VBMC, and the starting points handed to PyVBMC."""

from __future__ import annotations

import numpy as np

from torchshm.inference.start import StartSettings, find_start, latin_design, vbmc_start
from torchshm.inference.target import LogJointTarget


class _Peak:
    """A narrow Gaussian peak: log joint spans ~1e6 nats over the box, like dense data."""

    def __init__(self) -> None:
        self.mode = np.array([33.0, 9.0, 0.9, 2.0])
        self.scale = np.array([0.05, 0.01, 0.05, 0.2])

    def log_joint(self, theta: np.ndarray) -> np.ndarray:
        return -0.5 * np.sum(((np.asarray(theta) - self.mode) / self.scale) ** 2, axis=-1)


PLAUSIBLE = np.array([[20.0, 60.0], [1.0, 11.0], [0.2, 2.0], [0.2, 5.0]])
HARD = np.array([[10.0, 100.0], [0.0, 12.0], [0.0, 5.0], [0.0, 10.0]])


def test_defaults_follow_pyvbmc() -> None:
    s = StartSettings().resolved(4)
    assert (s.n_design, s.n_local, s.keep_threshold) == (10, 40, 600.0)
    assert StartSettings(n_design=3).resolved(12).n_design == 3
    assert StartSettings().resolved(12).n_design == 20


def test_latin_design_fills_the_plausible_box_reproducibly() -> None:
    d = latin_design(PLAUSIBLE, 10, seed=1)
    assert d.shape == (10, 4)
    assert np.all((d >= PLAUSIBLE[:, 0]) & (d <= PLAUSIBLE[:, 1]))
    bins = np.floor((d - PLAUSIBLE[:, 0]) / (PLAUSIBLE[:, 1] - PLAUSIBLE[:, 0]) * 10)
    assert all(len(set(bins[:, j])) == 10 for j in range(4))  # one point per stratum
    assert np.array_equal(d, latin_design(PLAUSIBLE, 10, seed=1))
    assert latin_design(PLAUSIBLE, 0, seed=1).shape == (0, 4)


def test_search_climbs_far_above_the_design_within_its_budget() -> None:
    peak = _Peak()
    target = LogJointTarget(peak, hard_bounds=HARD)
    find_start(target, PLAUSIBLE, HARD, StartSettings(), seed=0)
    assert len(target.y) <= 10 + 40
    design_best = max(target.y[:10])
    _, y = target.known()
    assert y[0] > design_best + 0.5 * abs(design_best)
    x0, (X, yk) = vbmc_start(target, 10, keep_threshold=600.0)
    assert x0.shape == (10, 4)
    assert np.all(yk >= yk[0] - 600.0) and yk[0] == y[0]
    assert np.array_equal(x0, X[:10])


def test_nothing_known_leaves_pyvbmc_its_default_start() -> None:
    target = LogJointTarget(_Peak(), hard_bounds=HARD)
    find_start(target, PLAUSIBLE, HARD, StartSettings(n_design=0, n_local=0), seed=0)
    assert target.y == []
    assert vbmc_start(target, 10, 600.0) == (None, None)
