"""The mode search that precedes VBMC, and the starting points handed to PyVBMC."""

from __future__ import annotations

import numpy as np

from torchshm.inference.start import (
    StartSettings,
    find_start,
    latin_design,
    probe_scales,
    vbmc_start,
)
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


def test_defaults_follow_pyvbmc_and_fit_the_budget() -> None:
    s = StartSettings().resolved(4)
    assert (s.n_design, s.n_local, s.probe, s.keep_threshold) == (10, 40, True, 600.0)
    assert StartSettings(n_design=3).resolved(12).n_design == 3
    assert StartSettings().resolved(12).n_design == 20
    small = StartSettings().resolved(4, budget=60)  # at most half the budget: 10 + 4 * 6 probes
    assert (small.n_design, small.probe, small.n_local) == (10, False, 20)
    tiny = StartSettings().resolved(2, budget=10)
    assert (tiny.n_design, tiny.n_local) == (5, 0)


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
    first = find_start(target, PLAUSIBLE, HARD, StartSettings(probe=False), seed=0)
    assert len(target.y) <= 10 + 40
    design_best = max(target.y[:10])
    X, y = target.known()
    assert y[0] > design_best + 0.5 * abs(design_best)
    assert np.array_equal(first, X[:1])


def test_probe_finds_the_local_scale_of_a_narrow_peak() -> None:
    peak = _Peak()
    target = LogJointTarget(peak, hard_bounds=HARD)
    star = probe_scales(target, peak.mode, 0.0, PLAUSIBLE, HARD, max_drop=40.0)
    assert star.shape == (8, 4) and len(target.y) <= 4 * 6
    steps = star - peak.mode
    assert np.all(np.count_nonzero(steps, axis=1) == 1)  # one parameter moved per star point
    assert np.allclose(steps[0::2], -steps[1::2])  # +h and -h
    drop = -peak.log_joint(star)
    assert np.all(drop <= 40.0)  # within 10 D nats
    # each step is the first of 5 %, 5 %/4, ... of the plausible width that is within 40 nats
    h = np.abs(steps).sum(axis=0) / 2
    first_step = 0.05 * (PLAUSIBLE[:, 1] - PLAUSIBLE[:, 0])
    assert np.all(np.isclose(h, first_step) | (4 * h / peak.scale > np.sqrt(80.0)))  # 4h: > 40 nats
    assert h[1] <= first_step[1] / 16  # the narrowest parameter needed the most reductions


def test_search_then_probe_gives_a_star_at_the_mode() -> None:
    target = LogJointTarget(_Peak(), hard_bounds=HARD)
    first = find_start(target, PLAUSIBLE, HARD, StartSettings(), seed=0)
    assert first.shape == (9, 4) and len(target.y) <= 10 + 40 + 4 * 6
    X, y = target.known()
    assert all(np.any(np.all(X == row, axis=1)) for row in first)
    assert np.any(np.all(first == X[0], axis=1))  # the best point is in the lead (a probe may improve it)
    assert y[0] > -50.0  # near the mode of a peak that spans ~1e6 nats over the box


def test_vbmc_start_leads_with_the_star_and_keeps_close_points() -> None:
    target = LogJointTarget(_Peak(), hard_bounds=HARD)
    first = find_start(target, PLAUSIBLE, HARD, StartSettings(), seed=0)
    x0, (X, y) = vbmc_start(target, first, 10, keep_threshold=600.0)
    assert x0.shape == (10, 4)
    assert np.array_equal(x0[: first.shape[0]], first)
    assert np.all(y >= y[0] - 600.0) and np.all(np.diff(y) <= 0)
    assert all(np.any(np.all(X == row, axis=1)) for row in x0)  # PyVBMC evaluates none again


def test_nothing_known_leaves_pyvbmc_its_default_start() -> None:
    target = LogJointTarget(_Peak(), hard_bounds=HARD)
    first = find_start(target, PLAUSIBLE, HARD, StartSettings(n_design=0, n_local=0), seed=0)
    assert target.y == [] and first.shape == (0, 4)
    assert vbmc_start(target, first, 10, 600.0) == (None, None)
