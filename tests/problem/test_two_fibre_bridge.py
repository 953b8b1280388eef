"""Acceptance 1 of the sensor-lines issue on bridge 705: a two-fibre campaign with dropouts.

The campaign is ``with_dropouts(synthetic_campaign(lines=2))`` (5 % of the readings lost at
random and one 40 cm stretch per load case), written to a file and read back as the command
line reads it; its masked log-likelihood must equal the one of the same data with those
readings deleted by hand (one problem per load case and line) to 1e-10.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm import Measurements, Problem, bridge705, load_measurements
from torchshm.casestudy import synthetic_campaign
from torchshm.data import with_dropouts

pytestmark = pytest.mark.slow  # the top-face truth is one finite element solve (~10 s)

THETA = np.array([[37.6, 9.0, 1.0, 2.0], [41.0, 11.8, 3.0, 6.5], [33.0, 7.5, 0.3, 0.2]])


@pytest.fixture(scope="module")
def campaign() -> Measurements:
    return with_dropouts(synthetic_campaign(0, lines=2), fraction=0.05, gap=0.4, seed=0)


def test_two_fibre_campaign(campaign: Measurements) -> None:
    one = synthetic_campaign(0)
    assert campaign.lines == ("bottom", "top") and campaign.n == 2 * one.n
    bottom = campaign.line_slices()["bottom"]
    kept = campaign.mask[:, bottom]
    np.testing.assert_array_equal(campaign.y[:, bottom][kept], one.y[kept])  # bottom line = one fibre
    lost = (~campaign.mask).sum(axis=1)
    assert np.all(lost >= round(0.05 * campaign.n)) and np.all(lost <= round(0.05 * campaign.n) + 5)
    top, both = campaign.y[4, campaign.line_slices()["top"]], kept[4] & campaign.mask[4, campaign.line_slices()["top"]]
    corr = np.corrcoef(campaign.y[4, bottom][both], top[both])[0, 1]
    assert corr < -0.95  # bending dominates: the top face is in compression where the bottom is in tension


@pytest.mark.parametrize("kernel", ["matern32", "squared_exponential"])
def test_masked_equals_deleted_by_hand(campaign: Measurements, tmp_path: Path, kernel: str) -> None:
    path = campaign.save(tmp_path / "two_fibre.csv")
    m = load_measurements(path).select([39.8, 47.5])
    assert m.n_missing == int((~campaign.mask[4:6]).sum()) > 0
    model = bridge705(lines=2)
    got = Problem(model, m, kernel).log_likelihood(THETA)
    want = np.zeros(len(THETA))
    for i, load in enumerate(m.loads):
        for label, part in m.line_slices().items():
            keep = np.arange(part.start, part.stop)[m.mask[i, part]]
            one = Measurements(m.x[keep], m.y[i:i + 1, keep], [load], m.sigma_e, line=[label] * keep.size)
            want += Problem(model, one, kernel).log_likelihood(THETA)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)
