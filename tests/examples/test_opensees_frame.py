"""The OpenSeesPy frame example: the model against beam theory, its independence of what ran
before in the process, and its README command with a small budget in joblib workers (slow)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from tests.cli.conftest import CONSOLE_SCRIPT, REPO, run_cli
from tests.docs_blocks import run_by
from tests.examples.test_calculix_slab import readme_command

sys.path.insert(0, str(REPO))
from examples.opensees_frame.frame import PortalFrame  # noqa: E402

EXAMPLE = REPO / "examples" / "opensees_frame"
BUDGET = ["method=emulator", "method.max_model_evaluations=5", "method.n_steps=20",
          "method.final_steps=30", "method.error_draws=2", "predict.n=100", "data.resolution=1"]


def test_pinned_joints_give_the_simply_supported_beam() -> None:
    """k_j = 1 N·m/rad: the beam carries P a b / L at the load like a simply supported beam;
    bottom strain M (h/2) / (E I) within 0.01 % of the largest (the columns' axial push: none)."""
    model = PortalFrame(loads=(3.2,))
    strain = model(torch.tensor([30.0, 0.0], dtype=torch.float64))[0].numpy()
    x, a = model.x.numpy(), 3.2
    moment = np.where(x <= a, 100e3 * (8.0 - a) * x / 8.0, 100e3 * a * (8.0 - x) / 8.0)
    expected = 1e6 * moment * 0.3 / (30e9 * 0.3 * 0.6**3 / 12)
    np.testing.assert_allclose(strain, expected, atol=1e-4 * expected.max())


def test_calls_do_not_depend_on_earlier_calls() -> None:
    model = PortalFrame()
    a, b = torch.tensor([30.0, 7.8], dtype=torch.float64), torch.tensor([45.0, 6.2], dtype=torch.float64)
    first = model(a)
    model(b)
    assert torch.equal(model(a), first)
    assert torch.equal(model(torch.stack([b, a]))[1], first)
    stiff = model(torch.tensor([30.0, 12.0], dtype=torch.float64))[1]
    assert stiff[0] < -50.0 and first[1, 0] < 0 and stiff[0] < first[1, 0]  # hogging grows with k_j


def test_truth_json_matches_the_campaign_file() -> None:
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    head = (EXAMPLE / "campaign.csv").read_text().splitlines()[:4]
    attrs = json.loads(next(line for line in head if line.startswith("# attrs="))[len("# attrs="):])
    names = ("E", "log10_k_j", "sigma_a", "length")
    assert {k: attrs[f"truth_{k}"] for k in names} == {k: truth[k] for k in names}


@pytest.mark.slow
def test_readme_command_runs_in_joblib_workers(tmp_path: Path) -> None:
    assert CONSOLE_SCRIPT.is_file()
    args = readme_command(EXAMPLE, run_by(__file__))
    assert "executor=joblib" in args and "executor.n_jobs=2" in args
    args += [*BUDGET, f"store={tmp_path / 'store.sqlite'}", f"hydra.run.dir={tmp_path / 'run'}"]
    result = run_cli(args, REPO, env={"PYTHONPATH": str(REPO)})
    assert result.returncode == 0, result.stderr[-2000:]
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert record["n_model_evaluations"] == 5 and record["names"] == ["E", "log10_k_j", "sigma_a", "length"]
