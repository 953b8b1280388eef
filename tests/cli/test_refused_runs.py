"""A refused run leaves no run folder behind (no empty log to wonder about)."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_bad_input import assert_one_line_error


@pytest.mark.parametrize("args, fragment", [
    (["priors.E_c.a=100", "priors.E_c.b=10"], "lo < hi"),
    (["method=vbmc", "method.max_fun_evals=5"], "method.max_fun_evals"),
    (["priors.length={dist:fixed,value:0}"], "fixed length must be > 0"),
])
def test_refused_run_leaves_no_run_folder(cli, tmp_path: Path, args: list[str], fragment: str) -> None:
    assert_one_line_error(cli(*args), fragment)
    assert not (tmp_path / "runs").exists(), sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))


def test_an_existing_runs_folder_is_kept(cli, tmp_path: Path) -> None:
    (tmp_path / "runs" / "old").mkdir(parents=True)
    (tmp_path / "runs" / "old" / "identify.log").write_text("a finished run\n")
    assert_one_line_error(cli("priors.E_c.a=100", "priors.E_c.b=10"), "lo < hi")
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["old"]


BROKEN_MODEL = '''
import torch


class Broken:
    """The two-span beam's positions and loads, but strains of the wrong shape."""

    names = ("E", "log10_k_A", "log10_k_C")

    def __init__(self):
        self.x = torch.round(torch.arange(0.0, 40.05, 0.1, dtype=torch.float64) * 1e6) / 1e6
        self.loads = torch.arange(6.0, 38.5, 4.0, dtype=torch.float64)

    def __call__(self, theta):
        return torch.zeros(tuple(theta.shape[:-1]) + (2, 5), dtype=torch.float64)
'''


@pytest.mark.slow
def test_model_of_the_wrong_shape_ends_in_one_line_naming_it(cli, tmp_path: Path) -> None:
    example = Path(__file__).resolve().parents[2] / "examples" / "two_span_beam"
    (tmp_path / "broken_model.py").write_text(BROKEN_MODEL)
    (tmp_path / "conf" / "model").mkdir(parents=True)
    (tmp_path / "conf" / "priors").mkdir()
    (tmp_path / "conf" / "model" / "broken.yaml").write_text("_target_: broken_model.Broken\n")
    (tmp_path / "conf" / "priors" / "beam.yaml").write_text(
        (example / "conf" / "priors" / "two_span_beam.yaml").read_text())
    result = cli("--config-dir", str(tmp_path / "conf"), "model=broken", "priors=beam",
                 f"data.path={example / 'campaign.csv'}", "data.loads=[10.0,30.0]", "predict.loads=[18.0]",
                 "resolution=0.5", "store=runs.db")
    line = assert_one_line_error(result, "model output has shape (2, 5), expected (L, n) = (9, 401)",
                                 "the model must return float strains")  # after one run
    assert "see the evaluation store" not in line
