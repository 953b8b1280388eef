"""The README's "Your own structure" commands, as written, on the two-span beam example.

Both commands are the README block marked ``run-by`` this file, read through the docs test's
collector (``tests.docs_blocks``) and run from the repository root; only a small budget and the
output folder are appended (slow: about a minute per job).
"""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from tests.cli.conftest import CONSOLE_SCRIPT, REPO, run_cli
from tests.docs_blocks import commands, run_by

pytestmark = pytest.mark.slow

BUDGET = ["method.max_model_evaluations=15", "method.n_steps=60", "method.final_steps=60",
          "method.error_draws=2", "data.resolution=2", "predict.n=200"]
OUTPUTS = ("posterior.nc", "summary.csv", "corner.png", "trace.png", "predictive.csv",
           "predictive.png", "run.json", "identify.log")


def readme_commands() -> list[list[str]]:
    """The commands of the blocks this file runs (README.md, "Your own structure", and
    conf/README.md, which shows the same two commands), split as the shell does, without the
    program; run once for both."""
    blocks = run_by(__file__)
    assert [b.path for b in blocks] == ["README.md", "conf/README.md"], blocks
    readme, conf = (commands(b) for b in blocks)
    assert readme == conf, "conf/README.md shows the README's two commands: keep them the same"
    assert all(c[0] == ".venv/bin/torchshm-identify" for c in readme)
    return [c[1:] for c in readme]


def test_readme_commands_are_the_run_and_the_kernel_sweep() -> None:
    run, sweep = readme_commands()
    assert "-m" not in run and "-m" in sweep
    assert "kernel=exponential,matern32,matern52" in sweep


def test_example_run_writes_every_output(tmp_path: Path) -> None:
    assert CONSOLE_SCRIPT.is_file()
    args = readme_commands()[0]
    result = run_cli([*args, *BUDGET, f"hydra.run.dir={tmp_path / 'run'}"], REPO)
    assert result.returncode == 0, result.stderr
    for name in OUTPUTS:
        assert (tmp_path / "run" / name).is_file(), name
    assert any((tmp_path / "run" / "tb").iterdir())
    assert "log10_k_A" in result.stdout


def test_example_kernel_sweep_writes_the_comparison(tmp_path: Path) -> None:
    args = readme_commands()[1]
    result = run_cli([*args, *BUDGET, f"hydra.sweep.dir={tmp_path}"], REPO)
    assert result.returncode == 0, result.stderr
    with open(tmp_path / "comparison.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["job"] for r in rows] == ["kernel=exponential", "kernel=matern32", "kernel=matern52"]
    assert all(r["status"] == "ok" and r["elbo"] and r["holdout_coverage"] for r in rows)
    assert sorted(r["jeffreys"] for r in rows).count("best") == 1
    assert (tmp_path / "comparison.md").is_file() and (tmp_path / "bayes_factors.csv").is_file()
    for row in rows:
        for name in OUTPUTS:
            assert (tmp_path / row["folder"] / name).is_file(), (row["folder"], name)
