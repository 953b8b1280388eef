"""The shipped synthetic campaign: reproducible, consistent with the model, realistic errors."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.casestudy.campaign import (
    CAMPAIGN_PATH,
    CampaignTruth,
    campaign_truth,
    discrepancy_summary,
    synthetic_campaign,
    write_campaign,
)
from torchshm.data.measurements import Measurements
from torchshm.casestudy import bridge705
from torchshm.casestudy.truth import TruthConfig


def digest(m: Measurements) -> str:
    return hashlib.sha256(m.y.tobytes() + m.x.tobytes() + m.loads.tobytes()).hexdigest()


def test_campaign_shape_and_metadata() -> None:
    m = synthetic_campaign(0)
    model = bridge705()
    assert isinstance(m, Measurements)
    assert m.y.shape == (12, 351) and m.y.dtype == np.float64
    np.testing.assert_array_equal(m.x, model.x.numpy())
    np.testing.assert_array_equal(m.loads, model.loads.numpy())
    assert m.pitch == pytest.approx(0.1)
    assert m.sigma_e == pytest.approx(0.1)
    assert m.attrs["truth_E_c"] == 35.0 and m.attrs["truth_log10_K_r"] == 11.5


def test_same_seed_same_data_different_seed_different_data() -> None:
    first, again = synthetic_campaign(0), synthetic_campaign(0)
    assert first.equals(again)
    first.y[0, 0] += 1.0  # a caller's change does not leak into later loads
    assert not first.equals(synthetic_campaign(0))
    assert not np.array_equal(synthetic_campaign(0).y, synthetic_campaign(1).y)


def test_same_seed_same_data_in_another_process() -> None:
    code = (
        "import hashlib; from torchshm.casestudy.campaign import synthetic_campaign; m = synthetic_campaign(0); "
        "print(hashlib.sha256(m.y.tobytes() + m.x.tobytes() + m.loads.tobytes()).hexdigest())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == digest(synthetic_campaign(0))


def test_noise_and_offsets_have_the_stated_sizes() -> None:
    truth = campaign_truth()
    residual = synthetic_campaign(3).y - truth.strain
    offsets = residual.mean(axis=1)
    within = residual - offsets[:, None]
    assert np.std(within) == pytest.approx(truth.sigma_e, rel=0.05)
    assert 0.0 < np.abs(offsets).max() < 5 * truth.offset_sd
    pooled = np.concatenate([synthetic_campaign(s).y.mean(axis=1) - truth.strain.mean(axis=1) for s in range(20)])
    assert np.std(pooled) == pytest.approx(np.hypot(truth.offset_sd, truth.sigma_e / np.sqrt(351)), rel=0.2)


def test_file_was_made_by_the_current_model_and_truth() -> None:
    truth = campaign_truth()
    assert truth.attrs["model_identity"] == bridge705().identity
    assert json.loads(str(truth.attrs["truth_config"])) == json.loads(json.dumps(asdict(TruthConfig())))


def test_discrepancy_at_the_truth_is_realistic() -> None:
    truth = campaign_truth()
    model = bridge705()
    eta = model(torch.tensor([truth.attrs["truth_E_c"], truth.attrs["truth_log10_K_r"]])).numpy()
    rms, length = discrepancy_summary(truth.strain - eta, 0.1)
    assert 0.5 <= rms <= 2.0
    assert 0.3 <= length <= 5.0
    assert 20.0 <= np.abs(truth.strain).max() <= 80.0


def test_discrepancy_summary_recovers_an_exponential_correlation() -> None:
    rng = np.random.default_rng(0)
    phi, n = np.exp(-0.1 / 1.5), 200_000  # AR(1) at 0.1 m pitch with correlation length 1.5 m
    e = rng.normal(size=n) * np.sqrt(1 - phi**2)
    d = np.empty(n)
    d[0] = rng.normal()
    for i in range(1, n):
        d[i] = phi * d[i - 1] + e[i]
    rms, length = discrepancy_summary(d.reshape(4, -1), 0.1)
    assert rms == pytest.approx(1.0, rel=0.05)
    assert length == pytest.approx(1.5, rel=0.1)


def test_write_and_read_a_campaign_file(tmp_path: Path) -> None:
    x, loads = np.array([0.0, 0.1, 0.2]), np.array([1.0, 2.0])
    strain = np.arange(6.0).reshape(2, 3)
    attrs = {"truth_E_c": 30.0, "truth_log10_K_r": 10.0, "sigma_e": 0.2, "offset_sd": 0.0, "description": "t"}
    path = write_campaign(CampaignTruth(x, loads, strain, attrs), tmp_path / "c.nc")
    back = campaign_truth(path)
    np.testing.assert_array_equal(back.strain, strain)
    assert back.attrs == attrs
    m = synthetic_campaign(5, path=path)
    assert m.sigma_e == 0.2 and np.std(m.y - strain) == pytest.approx(0.2, rel=0.9)
    with pytest.raises(FileNotFoundError, match="campaign file"):
        synthetic_campaign(0, path=tmp_path / "missing.nc")


def test_shipped_file_is_in_the_package() -> None:
    assert CAMPAIGN_PATH.name == "bridge705_campaign.nc" and CAMPAIGN_PATH.is_file()
