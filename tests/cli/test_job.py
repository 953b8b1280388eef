"""``prepare_job`` refuses a held-out predictive that would not fit in memory before any model run."""

from __future__ import annotations

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

import torchshm
from torchshm.cli import job
from torchshm.config import CONF_DIR, CONFIG_NAME, register_configs, to_settings

ROOT = Path(__file__).resolve().parents[2]


class Untouchable:
    """The bridge's positions, load cases and parameters; calling it fails the test."""

    def __init__(self) -> None:
        model = torchshm.bridge705_surrogate()
        self.x, self.loads, self.names = model.x, model.loads, model.names

    def __call__(self, theta_p: object) -> None:
        raise AssertionError("a model run before the check of predict.n")


def test_oversized_predict_n_is_refused_before_any_model_run(monkeypatch: pytest.MonkeyPatch) -> None:
    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        settings = to_settings(compose(CONFIG_NAME, overrides=["predict.loads=[47.5,55.1]",
                                                               "predict.n=1000000000000"]))
    monkeypatch.setattr(job, "build_model", lambda settings, base: Untouchable())
    with pytest.raises(ValueError) as err:
        job.prepare_job(settings, ROOT)
    line = str(err.value)
    assert "\n" not in line and line.startswith("predict.n=1,000,000,000,000 draws of ")
    assert "x 2 held-out load cases need about" in line and "GiB of" not in line
    assert "use predict.n=" in line and "or fewer predict.loads" in line and "keep=" not in line
