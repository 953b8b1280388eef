"""Helpers around composition: numeric group options and run-folder names."""

from __future__ import annotations

import pytest

from torchshm.config import normalize_overrides, run_dirname
from torchshm.config.store import MAX_DIRNAME


@pytest.mark.parametrize(
    "given, expected",
    [
        (["resolution=0.5"], ["resolution='0.5'"]),
        (["resolution=1.0"], ["resolution='1'"]),
        (["resolution=.2"], ["resolution='0.2'"]),
        (["resolution=0.1,0.5,4"], ["resolution='0.1','0.5','4'"]),
        (["resolution='0.5'"], ["resolution='0.5'"]),
        (["data.resolution=0.5", "kernel=matern52"], ["data.resolution=0.5", "kernel=matern52"]),
        (["resolution=foo"], ["resolution=foo"]),
        (["-m", "resolution=2"], ["-m", "resolution='2'"]),
    ],
)
def test_normalize_overrides(given: list[str], expected: list[str]) -> None:
    assert normalize_overrides(given) == expected


def test_run_dirname() -> None:
    assert run_dirname("", "_") == ""
    assert run_dirname("", "", "default") == "default"
    assert run_dirname("kernel=matern52,resolution='0.5'", "_") == "_kernel=matern52,resolution=0.5"
    assert run_dirname("data.path=/a/b.csv") == "data.path=_a_b.csv"
    long = run_dirname("x=" + "y" * 500)
    assert len(long) == MAX_DIRNAME and "/" not in long
    assert long != run_dirname("x=" + "y" * 499)


def test_run_dir_of_default_run_has_no_suffix(compose_cfg) -> None:
    cfg = compose_cfg(return_hydra_config=True)
    assert cfg.hydra.run.dir.count("/") == 2 and not cfg.hydra.run.dir.endswith("_")
    cfg = compose_cfg(*normalize_overrides(["resolution=0.5"]), return_hydra_config=True)
    assert cfg.hydra.run.dir.endswith("_resolution=0.5")
