"""The CalculiX slab example: its README command, as written, with a small budget (slow: it
runs ccx), and its campaign file against truth.json."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from tests.cli.conftest import CONSOLE_SCRIPT, REPO, run_cli
from tests.docs_blocks import Block, commands, run_by

EXAMPLE = REPO / "examples" / "calculix_slab"
#: a smoke budget: the initial design of 5 runs, short chains, every 1 m of the fibre (the README
#: states the full results)
BUDGET = ["method=emulator", "method.max_model_evaluations=5", "method.n_steps=20",
          "method.final_steps=30", "method.error_draws=2", "predict.n=100", "data.resolution=1"]


def readme_command(example: Path, blocks: list[Block]) -> list[str]:
    """The one ``torchshm-identify`` command of an example's README, from ``blocks``: those
    marked ``run-by`` the calling test file (``run_by(__file__)``), split as the shell does."""
    assert [b.path for b in blocks] == [(example / "README.md").relative_to(REPO).as_posix()], blocks
    lines = commands(blocks[0])
    assert len(lines) == 1 and lines[0][0] == ".venv/bin/torchshm-identify"
    assert not any(arg.startswith("method=") for arg in lines[0]), "the README runs the default method"
    return lines[0][1:]


def test_truth_json_matches_the_campaign_file() -> None:
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    head = (EXAMPLE / "campaign.csv").read_text().splitlines()[:4]
    attrs = json.loads(next(line for line in head if line.startswith("# attrs="))[len("# attrs="):])
    assert {k: attrs[f"truth_{k}"] for k in ("E", "log10_k_B", "sigma_a", "length")} == \
        {k: truth[k] for k in ("E", "log10_k_B", "sigma_a", "length")}
    assert "# sigma_e=2.0" in head and truth["sigma_m"] == 0.02


def test_config_builds_the_python_model(monkeypatch: pytest.MonkeyPatch) -> None:
    """conf/model/calculix_slab.yaml and slab.calculix_slab() are one model for the store."""
    import sys

    import yaml

    from torchshm.cli.models import instantiate_model

    sys.path.insert(0, str(REPO))
    from examples.calculix_slab.slab import calculix_slab

    monkeypatch.chdir(REPO)  # the config's paths are relative to where the command runs
    spec = yaml.safe_load((EXAMPLE / "conf" / "model" / "calculix_slab.yaml").read_text())
    built = instantiate_model(spec, REPO)
    assert built.identity == calculix_slab().identity and built.keep == "failed"
    assert built.x.shape == (201,) and built.loads.tolist() == [4.0, 8.0, 12.0, 16.0]


@pytest.mark.slow
def test_readme_command_runs_calculix_and_keeps_no_successful_folder(tmp_path: Path) -> None:
    assert shutil.which("ccx"), "CalculiX is not installed: bash scripts/install.sh (as root) or apt-get install calculix-ccx"
    assert CONSOLE_SCRIPT.is_file()
    args = [*readme_command(EXAMPLE, run_by(__file__)), *BUDGET, f"store={tmp_path / 'store.sqlite'}",
            f"model.workdir={tmp_path / 'fe'}", f"hydra.run.dir={tmp_path / 'run'}"]
    result = run_cli(args, REPO, env={"PYTHONPATH": str(REPO)})
    assert result.returncode == 0, result.stderr[-2000:]
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert record["n_model_evaluations"] == 5 and record["names"] == ["E", "log10_k_B", "sigma_a", "length"]
    with open(tmp_path / "fe" / "index.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 5 and {(r["status"], r["kept"]) for r in rows} == {("ok", "no")}
    assert list((tmp_path / "fe").glob("run-*")) == []
    log = (tmp_path / "run" / "identify.log").read_text()
    assert "run folders: 5 runs (5 ok), 0 folders kept (keep='failed')" in log
