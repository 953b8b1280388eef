"""The camera example's README command with a tiny budget: a DIC field (DICe files written from
muDIC's correlation of rendered images) read, identified and its held-out load case mapped end
to end (slow, ~30 s)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.docs_blocks import commands, run_by

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "plate_dic_camera"
#: a thinned field (every 12th point each way: 1,131 points, on element centres) and a budget far
#: below convergence
BUDGET = ["data.dic.every=12", "method.max_fun_evals=20", "method.n_samples=2000", "predict.n=50"]

pytestmark = pytest.mark.slow


def readme_commands() -> list[list[str]]:
    """The command(s) of the README block marked ``run-by`` this file (read by the docs test's
    collector), split as the shell does."""
    blocks = run_by(__file__)
    assert [b.path for b in blocks] == ["examples/plate_dic_camera/README.md"], blocks
    return commands(blocks[0])


def run(args: list[str]) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.run([sys.executable, *args], cwd=REPO, env=env, capture_output=True, text=True, timeout=600)


def test_truth_file_names_the_model_parameters() -> None:
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    assert set(k for k in truth if k.startswith("truth_")) == {"truth_E", "truth_log10_k"}
    assert truth["points"] >= 100_000 and len(truth["files"]) == len(truth["loads"])
    assert all((EXAMPLE / f).is_file() for f in truth["files"])


def test_readme_command_runs_with_a_tiny_budget(tmp_path: Path) -> None:
    (identify,) = readme_commands()
    assert identify[0] == ".venv/bin/torchshm-identify"
    assert "kernel=upscaled" in identify and "predict.loads=[1.0]" in identify
    out = tmp_path / "run"
    assert identify[-1] == "hydra.run.dir=runs/plate_dic_camera"
    result = run(["-m", "torchshm.cli.identify", *identify[1:-1], *BUDGET, f"hydra.run.dir={out}"])
    assert result.returncode == 0, result.stderr[-3000:]
    record = json.loads((out / "run.json").read_text())
    assert record["names"] == ["E", "log10_k", "sigma_a"]  # length: the element side, fixed
    assert (out / "posterior.nc").is_file() and (out / "predictive_map_1.png").is_file()
    (held_out,) = record["predictive"]
    assert held_out["load"] == 1.0 and held_out["n_points"] > 1000
