"""A refused run leaves no run folder behind (no empty log to wonder about)."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_bad_input import assert_one_line_error


@pytest.mark.parametrize("args, fragment", [
    (["priors.E_c.a=100", "priors.E_c.b=10"], "lo < hi"),
    (["method.max_fun_evals=5"], "method.max_fun_evals"),
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
