"""The executor settings shipped in conf/executor build the intended executors."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import submitit
import yaml

from torchshm.storage import evaluation_options, make_executor

CONF = Path(__file__).parents[2] / "conf" / "executor"


def _settings(name: str) -> dict:
    return yaml.safe_load((CONF / f"{name}.yaml").read_text())


@pytest.fixture
def fake_slurm(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make submitit believe it is on a Slurm cluster (an ``srun`` on PATH); nothing runs."""
    bin_folder = tmp_path / "bin"
    bin_folder.mkdir()
    (bin_folder / "srun").write_text("#!/bin/sh\nexit 1\n")
    (bin_folder / "srun").chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_folder}{os.pathsep}{os.environ['PATH']}")


def test_slurm_settings_give_the_sbatch_options(tmp_path: Path, fake_slurm: None) -> None:
    settings = _settings("slurm") | {"folder": str(tmp_path / "jobs")}
    executor = evaluation_options(**settings)["executor"]
    script = submitit.slurm.slurm._make_sbatch_string(
        command="python -m submitit.core._submit", folder=executor.folder, map_count=112,
        **executor.parameters,
    )
    for line in ("--partition=compute", "--time=30", "--cpus-per-task=4", "--mem=16GB",
                 "--array=0-111%20", "--job-name=torchshm-fe"):
        assert f"#SBATCH {line}" in script


def test_other_settings(tmp_path: Path) -> None:
    none = {"cores_per_run": None, "cores_env": []}
    assert evaluation_options(**_settings("serial")) == {"n_jobs": 1, "executor": None} | none
    assert evaluation_options(**_settings("joblib")) == {"n_jobs": 4, "executor": None} | none
    local = evaluation_options(**_settings("local") | {"folder": str(tmp_path)})["executor"]
    assert local.cluster == "local" and local.parameters["timeout_min"] == 60


def test_bad_executor_settings_are_one_line_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with pytest.raises(ValueError, match="unknown executor kind 'pbs'"):
        make_executor("pbs", tmp_path)
    with pytest.raises(ValueError, match="bad local executor parameter: Unknown argument") as info:
        make_executor("local", tmp_path, slurm_partitio="x")
    assert "\n" not in str(info.value)
    monkeypatch.setenv("PATH", str(tmp_path))  # a machine without Slurm
    with pytest.raises(ValueError, match="cannot make a slurm executor here"):
        make_executor("slurm", tmp_path)
