"""Run folders of an external program: run-0007-<hash> names, index.csv, the keep policy and
the disk used (shared by worker processes)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.forward import ExternalModel, ExternalModelError
from torchshm.storage import EvaluationStore, evaluate

X, LOADS = np.linspace(0.0, 1.0, 4), np.array([1.0, 2.0])
#: writes strain = theta_0 (and 100 kB of padding), fails for theta_0 < 0
PROGRAM = (
    "import json, os, sys, numpy as np\n"
    "p = json.load(open(os.environ['TORCHSHM_PARAMS']))\n"
    "open('big.out', 'wb').write(b'0' * 100_000)\n"
    "if p['theta_p'][0] < 0: sys.exit('negative')\n"
    "np.savez(os.environ['TORCHSHM_OUTPUT'], strain=np.full((len(p['loads']), len(p['x'])), p['theta_p'][0]))\n"
)


def _model(tmp_path: Path, **kwargs: object) -> ExternalModel:
    script = tmp_path / "program.py"
    script.write_text(PROGRAM)
    return ExternalModel([sys.executable, str(script)], X, LOADS, workdir=tmp_path / "runs",
                         names=["a", "b"], **kwargs)


def _index(model: ExternalModel) -> list[dict[str, str]]:
    with open(model.workdir / "index.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def test_default_keeps_only_failed_folders_and_indexes_every_run(tmp_path: Path) -> None:
    model = _model(tmp_path)
    assert model.keep == "failed"
    model(torch.tensor([[1.0, 2.0], [3.0, 4.0]], dtype=torch.float64))
    with pytest.raises(ExternalModelError, match="program exited with status 1"):
        model(torch.tensor([-1.0, 5.0], dtype=torch.float64))
    rows = _index(model)
    assert [r["run"] for r in rows] == ["1", "2", "3"]
    assert [(r["status"], r["kept"]) for r in rows] == [("ok", "no"), ("ok", "no"), ("failed", "yes")]
    assert rows[0]["theta_p"] == "a=1.0 b=2.0" and rows[2]["error"].startswith("program exited with status 1")
    assert rows[2]["folder"].startswith("run-0003-") and len(rows[2]["folder"]) == len("run-0003-") + 8
    assert sorted(p.name for p in model.workdir.glob("run-*")) == [rows[2]["folder"]]
    assert all(int(r["bytes"]) > 100_000 for r in rows)
    assert 100_000 < model.disk_used < 120_000  # the failed folder and the index
    assert model.runs_summary().startswith("3 runs (2 ok, 1 failed), 1 folders kept (keep='failed'), 0.1 MB in ")


@pytest.mark.parametrize(("keep", "kept"), [("all", 2), ("none", 0)])
def test_keep_all_and_none(tmp_path: Path, keep: str, kept: int) -> None:
    model = _model(tmp_path, keep=keep)
    model(torch.tensor([1.0, 2.0], dtype=torch.float64))
    with pytest.raises(ExternalModelError):
        model(torch.tensor([-1.0, 2.0], dtype=torch.float64))
    assert len(list(model.workdir.glob("run-*"))) == kept
    assert [r["kept"] for r in _index(model)] == (["yes", "yes"] if kept else ["no", "no"])


def test_same_theta_twice_gets_two_numbers_and_one_hash(tmp_path: Path) -> None:
    model = _model(tmp_path, keep="all")
    model(torch.tensor([[1.0, 2.0], [1.0, 2.0]], dtype=torch.float64))
    names = sorted(p.name for p in model.workdir.glob("run-*"))
    assert [n[:8] for n in names] == ["run-0001", "run-0002"] and names[0][9:] == names[1][9:]


def test_worker_processes_share_the_numbering_and_the_index(tmp_path: Path) -> None:
    model = _model(tmp_path)
    theta = np.column_stack([np.arange(1.0, 7.0), np.zeros(6)])
    theta[4, 0] = -1.0
    res = evaluate(model, theta, store=EvaluationStore(tmp_path / "store.sqlite"), n_jobs=2)
    assert res.ok.tolist() == [True] * 4 + [False, True]
    rows = _index(model)
    assert sorted(int(r["run"]) for r in rows) == list(range(1, 7))
    assert len({r["folder"] for r in rows}) == 6
    assert sorted(r["status"] for r in rows) == ["failed"] + ["ok"] * 5
    assert [p.name for p in model.workdir.glob("run-*")] == [r["folder"] for r in rows if r["status"] == "failed"]


def test_unknown_keep_is_refused() -> None:
    with pytest.raises(ValueError, match="keep must be one of failed, all, none, got 'some'"):
        ExternalModel(["true"], X, LOADS, keep="some")
