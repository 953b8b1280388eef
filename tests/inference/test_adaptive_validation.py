"""The batch check's bound on the witness (:attr:`BatchCheck.witness_scale`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from torchshm.inference.adaptive.validation import WITNESS_LEVEL, BatchCheck


def _check(error: np.ndarray, sd: np.ndarray) -> BatchCheck:
    return BatchCheck(1.0, np.abs(error), sd, sd)


def test_scale_is_the_upper_confidence_bound_of_the_variance_ratio() -> None:
    sd = np.array([0.5, 1.0, 2.0, 1.0, 4.0])
    # errors a tenth of the sd: sum z^2 = 5 x 0.01, over the 5 % quantile of chi2(5) (1.1455)
    assert _check(0.1 * sd, sd).witness_scale == pytest.approx(0.05 / chi2.ppf(0.05, 5), rel=1e-12)
    assert _check(0.1 * sd, sd).witness_scale == pytest.approx(0.04365, abs=1e-5)
    assert _check(sd, sd).witness_scale == 1.0  # errors as large as predicted: never up
    assert _check(10 * sd, sd).witness_scale == 1.0


def test_a_calibrated_emulator_is_scaled_down_at_the_level_only() -> None:
    # errors drawn as the emulator says: the witness shrinks in WITNESS_LEVEL of the batches
    rng = np.random.default_rng(0)
    sd = np.exp(rng.normal(size=5))
    below = np.mean([_check(sd * rng.standard_normal(5), sd).witness_scale < 1.0
                     for _ in range(20000)])
    assert below == pytest.approx(WITNESS_LEVEL, abs=0.005)  # binomial sd 0.0015


def test_no_runs_or_no_sd_leave_the_witness_alone() -> None:
    assert BatchCheck(np.nan, np.zeros(0), np.zeros(0), np.zeros(0)).witness_scale == 1.0
    assert BatchCheck(1.0, np.ones(3), np.ones(3)).witness_scale == 1.0
    assert _check(np.ones(3), np.zeros(3)).witness_scale == 1.0
