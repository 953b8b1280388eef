"""The plate example's README command, as written: a 2-D image-correlation field identified end to
end, every truth inside its 95 % interval (slow: about a minute)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from tests.cli.conftest import CONSOLE_SCRIPT, REPO, run_cli
from tests.docs_blocks import commands, run_by

pytestmark = pytest.mark.slow

EXAMPLE = REPO / "examples" / "plate_dic"
TRUTH = {"E": 32.0, "log10_k": 6.5, "sigma_a": 4.0, "length": 0.3}


def readme_command() -> list[str]:
    """The one command of the example's README (its block marked ``run-by`` this file, read by
    the docs test's collector), split as the shell does."""
    blocks = run_by(__file__)
    assert [b.path for b in blocks] == ["examples/plate_dic/README.md"], blocks
    lines = commands(blocks[0])
    assert len(lines) == 1 and lines[0][0] == ".venv/bin/torchshm-identify"
    return lines[0][1:]


def test_truth_matches_the_campaign_file() -> None:
    head = (EXAMPLE / "campaign.csv").read_text().splitlines()[:4]
    attrs = json.loads(next(line for line in head if line.startswith("# attrs="))[len("# attrs="):])
    assert {k: attrs[f"truth_{k}"] for k in TRUTH} == TRUTH


def test_readme_run_identifies_every_parameter_within_its_95_interval(tmp_path: Path) -> None:
    assert CONSOLE_SCRIPT.is_file()
    result = run_cli([*readme_command(), f"hydra.run.dir={tmp_path / 'run'}"], REPO)
    assert result.returncode == 0, result.stderr
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert record["converged"] and record["names"] == list(TRUTH)
    with open(tmp_path / "run" / "summary.csv") as f:
        rows = {r["name"]: r for r in csv.DictReader(line for line in f if not line.startswith("#"))}
    for name, value in TRUTH.items():
        assert float(rows[name]["q2.5"]) < value < float(rows[name]["q97.5"]), (name, rows[name])
    for name in ("posterior.nc", "corner.png", "trace.png", "identify.log", "predictive.csv",
                 "predictive_map_0.75.png", "predictive_map_1.25.png"):
        assert (tmp_path / "run" / name).is_file(), name
    held_out = [row for row in record["predictive"] if row["line"] == "all"]
    assert [row["load"] for row in held_out] == [0.75, 1.25]
    assert all(row["coverage"] > 0.8 and row["r2"] > 0.8 for row in held_out), held_out


def test_predictive_view_of_a_field() -> None:
    import sys

    import numpy as np

    import torchshm
    from torchshm.predictive import prediction_view

    sys.path.insert(0, str(REPO))
    from examples.plate_dic.plate import PlateDIC

    m = torchshm.load_measurements(EXAMPLE / "campaign.csv")
    problem = torchshm.Problem(PlateDIC(), m.select([0.5]), priors={
        "E": torchshm.Uniform(10, 60), "log10_k": torchshm.Uniform(4, 9),
        "sigma_a": torchshm.Uniform(0, 20), "length": torchshm.Uniform(0, 2)})
    view = prediction_view(problem)
    assert tuple(view.x.shape) == (192, 2) and view.line is None and len(view.parts) == 1
    assert np.isfinite(problem.log_joint(np.array([32.0, 6.5, 4.0, 0.3])))
