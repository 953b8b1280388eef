"""Sensor positions and load cases from values, a range or a file (Python and Hydra config)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.cli.models import instantiate_model
from torchshm.forward import ExternalModel, load_axis


def test_range_is_linspace_with_both_ends() -> None:
    x = load_axis({"start": 0.0, "stop": 20.0, "num": 201})
    np.testing.assert_array_equal(x, np.linspace(0.0, 20.0, 201))
    assert x[1] == pytest.approx(0.1, abs=1e-15) and x[-1] == 20.0


@pytest.mark.parametrize(("name", "text"), [
    ("one.csv", "0.0\n0.5\n1.0\n"),
    ("header.csv", "# sensors of fibre 1\nx\n0.0\n0.5\n1.0\n"),
    ("table.csv", "id,x,label\n1,0.0,7\n2,0.5,8\n3,1.0,9\n"),
    ("spaces.txt", "0.0\n0.5\n1.0\n"),
])
def test_text_files_one_column_or_the_named_one(tmp_path: Path, name: str, text: str) -> None:
    path = tmp_path / name
    path.write_text(text)
    np.testing.assert_array_equal(load_axis(path), [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(load_axis(str(path)), [0.0, 0.5, 1.0])


def test_npy_file_and_tensor(tmp_path: Path) -> None:
    np.save(tmp_path / "x.npy", np.array([1.0, 2.0]))
    np.testing.assert_array_equal(load_axis(tmp_path / "x.npy"), [1.0, 2.0])
    np.testing.assert_array_equal(load_axis(torch.tensor([3.0, 4.0])), [3.0, 4.0])


@pytest.mark.parametrize(("values", "message"), [
    ({"start": 0, "stop": 1}, "exactly the keys start, stop, num"),
    ({"start": 0, "stop": 1, "num": 0}, "num must be a positive integer"),
    ({"start": 0, "stop": 1, "num": 2.5}, "num must be a positive integer"),
    ({"start": "a", "stop": 1, "num": 3}, "start and stop must be numbers"),
    ("no/such/file.csv", "x: no file no/such/file.csv"),
    ([[0.0, 1.0]], "non-empty 1-D array of finite values"),
    ([0.0, float("nan")], "non-empty 1-D array of finite values"),
])
def test_bad_axes_are_refused_in_one_line(values: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_axis(values)


def test_bad_files_are_refused(tmp_path: Path) -> None:
    (tmp_path / "two.csv").write_text("1,2\n3,4\n")
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    (tmp_path / "x.json").write_text("[1]")
    np.save(tmp_path / "m.npy", np.zeros((2, 2)))
    for name, message in [("two.csv", "2 columns and no header"), ("other.csv", "no column 'x'"),
                          ("x.json", "unknown format"), ("m.npy", "expected one column")]:
        with pytest.raises(ValueError, match=message):
            load_axis(tmp_path / name)


def test_external_model_and_hydra_config_take_a_range_and_a_file(tmp_path: Path) -> None:
    (tmp_path / "loads.csv").write_text("loads\n9.8\n39.8\n")
    model = ExternalModel(["true"], {"start": 0.0, "stop": 2.0, "num": 5}, tmp_path / "loads.csv")
    assert model.x.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0] and model.loads.tolist() == [9.8, 39.8]
    spec = {"_target_": "torchshm.ExternalModel", "command": [sys.executable, "run.py"],
            "x": {"start": 0.0, "stop": 2.0, "num": 5}, "loads": str(tmp_path / "loads.csv")}
    built = instantiate_model(spec, tmp_path)
    assert torch.equal(built.x, model.x) and torch.equal(built.loads, model.loads)
    with pytest.raises(ValueError, match="model: _target_ 'torchshm.ExternalModel': ValueError: x: a range needs exactly"):
        instantiate_model({**spec, "x": {"start": 0.0, "num": 5}}, tmp_path)
