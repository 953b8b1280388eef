"""ExternalModel runs a stand-in FE program through files, and its failures are recorded."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch
from standin_fe import strain_field

from torchshm.forward import ExternalModel, ExternalModelError, model_identity
from torchshm.storage import EvaluationStore, evaluate

STANDIN = str(Path(__file__).parent / "standin_fe.py")
X = np.linspace(0.0, 2.0, 6)
LOADS = np.array([9.8, 39.8, 60.0])


def _model(tmp_path: Path, *args: str, **kwargs) -> ExternalModel:
    kwargs.setdefault("workdir", tmp_path / "runs")
    return ExternalModel([sys.executable, STANDIN, *args], X, LOADS, **kwargs)


def _expected(theta: list[float]) -> np.ndarray:
    return np.array(strain_field(theta, X.tolist(), LOADS.tolist()))


def test_results_equal_the_program_function(tmp_path: Path) -> None:
    model = _model(tmp_path, names=["E_c", "log10_K_r"], keep="all")
    theta = torch.tensor([[[35.0, 6.0], [20.0, 1.5]], [[80.0, 11.0], [12.5, 0.0]]])
    out = model(theta)
    assert out.shape == (2, 2, 3, 6) and out.dtype == torch.float64
    for index in np.ndindex(2, 2):
        np.testing.assert_allclose(out[index].numpy(), _expected(theta[index].tolist()),
                                   rtol=1e-12, atol=1e-12)
    folders = sorted((tmp_path / "runs").glob("run-*"))
    assert len(folders) == 4  # a fresh work folder per run
    params = json.loads((folders[0] / "params.json").read_text())
    assert params["names"] == ["E_c", "log10_K_r"] and len(params["theta_p"]) == 2
    assert params["x"] == X.tolist() and params["loads"] == LOADS.tolist()
    assert "stand-in FE run for {'E_c'" in (folders[0] / "run.log").read_text()


def test_csv_output_and_shell_command(tmp_path: Path) -> None:
    command = f"{sys.executable} {STANDIN} --output strains.csv"
    model = ExternalModel(command, X, LOADS, workdir=tmp_path, output="strains.csv")
    np.testing.assert_allclose(model(torch.tensor([42.0, 3.0])).numpy(), _expected([42.0, 3.0]),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    ("e_c", "message"),
    [
        (-1.0, r"program exited with status 2 \(work folder .*\); last output: .*negative modulus"),
        (998.0, r"no strain file strains.npz was written \(work folder"),
        (997.0, r"strains.npz is not a readable NPZ file"),
        (996.0, r"'strain' has shape \(3, 5\), expected \(L, n\) = \(3, 6\)"),
    ],
)
def test_program_failures_raise_clear_errors(tmp_path: Path, e_c: float, message: str) -> None:
    with pytest.raises(ExternalModelError, match=message):
        _model(tmp_path)(torch.tensor([e_c, 1.0]))


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, IndexError):
        return False
    return state not in ("Z", "X")


def test_failed_and_hanging_programs_are_failed_evaluations(tmp_path: Path) -> None:
    model = _model(tmp_path, timeout=2.0, kill_grace=1.0)
    store = EvaluationStore(tmp_path / "store.sqlite")
    theta = np.array([[30.0, 2.0], [-5.0, 2.0], [999.0, 2.0], [45.0, 7.0]])
    start = time.monotonic()
    result = evaluate(model, theta, store=store)
    assert time.monotonic() - start < 30.0
    assert result.ok.tolist() == [True, False, False, True]
    np.testing.assert_allclose(result.outputs[3], _expected([45.0, 7.0]), rtol=1e-12, atol=1e-12)
    failed_theta, errors = store.failures(model)
    assert failed_theta.tolist() == [[-5.0, 2.0], [999.0, 2.0]]
    assert errors[0].startswith("ExternalModelError: program exited with status 2")
    assert errors[1].startswith("ExternalModelError: program timed out after 2 s and was killed")
    assert "2 failed" in result.summary() and "timed out" in result.summary()
    child = int(next((tmp_path / "runs").glob("*/child.pid")).read_text())
    deadline = time.monotonic() + 5.0
    while _alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(child)  # the whole process group was killed
    again = evaluate(model, theta, store=store)
    assert again.n_new == 0 and again.ok.tolist() == [True, False, False, True]


def test_identity_depends_on_command_and_sensors(tmp_path: Path) -> None:
    a = _model(tmp_path)
    assert model_identity(a) == model_identity(_model(tmp_path / "elsewhere"))
    assert model_identity(a) != model_identity(_model(tmp_path, "--output", "strains.npz"))
    assert model_identity(a) != model_identity(ExternalModel(a.command, X[:-1], LOADS))
    assert model_identity(a) != model_identity(ExternalModel(a.command, X, LOADS[:2]))
    assert model_identity(a).startswith("ExternalModel-")
    assert model_identity(_model(tmp_path, identity="diana-bridge705-v3")) == "diana-bridge705-v3"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"command": []}, "command must be a non-empty list"),
        ({"command": "  "}, "command is empty"),
        ({"x": [0.0, np.nan]}, "x must be a non-empty 1-D array of finite values"),
        ({"loads": [[1.0]]}, "loads must be a non-empty 1-D array"),
        ({"timeout": 0}, "timeout must be positive"),
        ({"output": "strains.txt"}, "output must be a file name ending in .npz or .csv"),
    ],
)
def test_bad_arguments_are_one_line_errors(kwargs: dict, message: str) -> None:
    arguments = {"command": ["fe"], "x": X, "loads": LOADS, **kwargs}
    with pytest.raises(ValueError, match=message) as info:
        ExternalModel(**arguments)
    assert "\n" not in str(info.value)


def test_missing_program_and_wrong_parameter_count(tmp_path: Path) -> None:
    model = ExternalModel([str(tmp_path / "no-such-program")], X, LOADS, workdir=tmp_path)
    with pytest.raises(ExternalModelError, match="cannot start"):
        model(torch.tensor([1.0, 2.0]))
    with pytest.raises(ValueError, match="must be 2 finite values"):
        _model(tmp_path, names=["E_c", "log10_K_r"])(torch.tensor([1.0, 2.0, 3.0]))


def test_environment_and_kept_folders(tmp_path: Path) -> None:
    script = (
        "import os, json, numpy as np; p = json.load(open(os.environ['TORCHSHM_PARAMS'])); "
        "np.savez(os.environ['TORCHSHM_OUTPUT'], "
        "strain=np.full((len(p['loads']), len(p['x'])), p['theta_p'][0]))"
    )
    model = ExternalModel([sys.executable, "-c", script], X, LOADS, workdir=tmp_path / "r",
                          keep_workdirs=False)
    assert torch.equal(model(torch.tensor([7.0])), torch.full((3, 6), 7.0, dtype=torch.float64))
    assert list((tmp_path / "r").glob("run-*")) == []  # keep_workdirs=False is keep="failed"
    assert os.path.isdir(tmp_path / "r") and model.keep == "failed"
