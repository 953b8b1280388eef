"""Building the forward model from its config node (Hydra's instantiate at the edge)."""

from __future__ import annotations

from pathlib import Path

import pytest

from torchshm.cli.models import instantiate_model


def test_shipped_configs_build_the_bridge(tmp_path: Path) -> None:
    model = instantiate_model({"_target_": "torchshm.bridge705_surrogate"}, tmp_path)
    assert tuple(model.names) == ("E_c", "log10_K_r") and len(model.loads) == 12


def test_module_in_the_working_directory(tmp_path: Path) -> None:
    (tmp_path / "wd_model_mod.py").write_text(
        "class M:\n    def __init__(self, n=3):\n        self.x = list(range(n)); self.loads = [1.0]\n"
        "    def __call__(self, t):\n        return t\n")
    model = instantiate_model({"_target_": "wd_model_mod.M", "n": 4}, tmp_path)
    assert model.x == [0, 1, 2, 3]


@pytest.mark.parametrize("spec, fragment", [
    ({"_target_": "no_such_module_xyz.Model"}, "no_such_module_xyz"),
    ({"_target_": "torchshm.NoSuchModel"}, "NoSuchModel"),
    ({"_target_": "torchshm.bridge705_surrogate", "bogus": 1}, "bogus"),
    ({"_target_": "torchshm.paper_priors"}, "has no x or loads"),
    ({"name": "fe"}, "needs a _target_"),
])
def test_bad_model_config_is_one_line(tmp_path: Path, spec: dict, fragment: str) -> None:
    with pytest.raises(ValueError) as info:
        instantiate_model(spec, tmp_path)
    message = str(info.value)
    assert message.startswith("model:") and fragment in message and "\n" not in message


def test_external_program_from_its_config(tmp_path: Path) -> None:
    import torchshm

    spec = {"_target_": "torchshm.ExternalModel", "command": ["python", "/abs/run_fe.py"],
            "x": [0.0, 0.5, 1.0], "loads": [10.0, 20.0], "timeout": 600, "output": "strains.csv",
            "names": ["E", "k"], "workdir": str(tmp_path / "fe_runs")}
    model = instantiate_model(spec, tmp_path)
    assert isinstance(model, torchshm.ExternalModel)
    assert model.timeout == 600 and model.output == "strains.csv" and list(model.names) == ["E", "k"]
    assert model.x.tolist() == [0.0, 0.5, 1.0] and model.loads.tolist() == [10.0, 20.0]
