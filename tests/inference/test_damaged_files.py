"""A truncated or damaged posterior file (.nc): one line naming the file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import torchshm
from torchshm.inference import Posterior


def _posterior_file(tmp_path: Path) -> Path:
    samples = np.random.default_rng(0).normal(size=(400, 2))
    post = Posterior(names=["a", "b"], method="emcee", samples=samples, n_model_evaluations=10,
                     converged=True, diagnostics={}, priors={}, history={}, n_chains=4)
    path = tmp_path / "posterior.nc"
    post.save(path)
    return path


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty"])
def test_damaged_posterior_file(tmp_path: Path, damage: str) -> None:
    path = _posterior_file(tmp_path)
    data = path.read_bytes()
    assert np.allclose(torchshm.load_posterior(path).samples.mean(0),
                       np.random.default_rng(0).normal(size=(400, 2)).mean(0))
    path.write_bytes({"truncated": data[: len(data) // 2], "garbage": b"\x00garbage" * 99,
                      "empty": b""}[damage])
    with pytest.raises(ValueError, match="not a readable torchshm posterior file") as error:
        torchshm.load_posterior(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_missing_posterior_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no posterior file"):
        torchshm.load_posterior(tmp_path / "none.nc")
