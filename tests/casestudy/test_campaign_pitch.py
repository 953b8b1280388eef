"""synthetic_campaign at another pitch: same truth structure, default bit-identical."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm.casestudy.campaign import synthetic_campaign


def test_default_pitch_reads_the_shipped_file_bit_identically() -> None:
    a, b = synthetic_campaign(seed=3), synthetic_campaign(seed=3, pitch=0.1)
    assert a.y.tobytes() == b.y.tobytes() and a.x.tobytes() == b.x.tobytes()


@pytest.mark.slow
def test_dense_pitch_truth_matches_the_shipped_truth_at_shared_points() -> None:
    dense, coarse = synthetic_campaign(seed=0, pitch=0.05), synthetic_campaign(seed=0)
    assert dense.y.shape == (12, 701)
    np.testing.assert_allclose(dense.x[::2], coarse.x, atol=1e-9)
    from torchshm.casestudy.campaign import _dense_strain, campaign_truth

    _, strain = _dense_strain(0.05)
    np.testing.assert_allclose(strain[:, ::2], campaign_truth().strain, rtol=0.0, atol=1e-5)  # 6e-6 µε of 73 µε with default threads
    assert dense.attrs["truth_E_c"] == coarse.attrs["truth_E_c"]


def test_bad_pitch_is_one_line() -> None:
    with pytest.raises(ValueError, match="^synthetic_campaign: pitch must be a positive number"):
        synthetic_campaign(seed=0, pitch=-1.0)
