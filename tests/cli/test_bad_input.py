"""Each bad input, through the command line: exit status 2 and one line on stderr naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from torchshm.cli.errors import EXIT_BAD_INPUT

PREFIX = "torchshm-identify: error: "


def assert_one_line_error(result, *fragments: str) -> str:
    """The run failed with exactly one stderr line that starts with PREFIX and names the problem."""
    assert result.returncode == EXIT_BAD_INPUT, (result.returncode, result.stderr)
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(PREFIX), lines[0]
    assert "Traceback" not in result.stderr + result.stdout
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def test_missing_data_file(cli, tmp_path: Path) -> None:
    result = cli("data.path=no/such/file.csv")
    assert_one_line_error(result, "measurement file not found", str(tmp_path / "no/such/file.csv"))


def test_malformed_csv(cli, tmp_path: Path) -> None:
    (tmp_path / "bad.csv").write_text("load,x,strain\n39.8,0.0,1.0\n39.8,zero,2.0\n")
    assert_one_line_error(cli("data.path=bad.csv"), "bad.csv", "malformed row")


def test_csv_without_header(cli, tmp_path: Path) -> None:
    (tmp_path / "bad.csv").write_text("1,2,3\n")
    assert_one_line_error(cli("data.path=bad.csv"), "bad.csv", "header")


def test_malformed_netcdf(cli, tmp_path: Path) -> None:
    (tmp_path / "bad.nc").write_bytes(b"not a netcdf file")
    assert_one_line_error(cli("data.path=bad.nc"), "bad.nc", "not a readable netCDF file")


def test_unknown_file_type(cli, tmp_path: Path) -> None:
    (tmp_path / "strains.xlsx").write_text("x")
    assert_one_line_error(cli("data.path=strains.xlsx"), "unknown measurement file type")


@pytest.mark.parametrize("override, value", [("data.loads=[12.3]", "12.3"), ("predict.loads=[47.5,99]", "99")])
def test_unknown_load_case(cli, override: str, value: str) -> None:
    assert_one_line_error(cli(override), f"unknown load case {value}")


@pytest.mark.parametrize(
    "args, fragments",
    [
        (["kernel=foo"], ["Could not find 'kernel/foo'", "matern32"]),
        (["method=nuts"], ["Could not find 'method/nuts'", "vbmc"]),
        (["resolution=0.3"], ["Could not find 'resolution/0.3'", "0.5"]),
        (["+bogus=1"], ["unknown key 'bogus'"]),
        (["bogus=1"], ["Could not override 'bogus'"]),
        (["method.n_samples=8"], ["method.n_samples", "EmulatorConfig"]),
        (["kernel.name=foo"], ["kernel.name=foo", "expected one of"]),
        (["seed=x"], ["seed=x", "Integer"]),
        (["kernel=["], ["cannot parse override 'kernel=['"]),
    ],
)
def test_unknown_or_mistyped_config_option(cli, args: list[str], fragments: list[str]) -> None:
    assert_one_line_error(cli(*args), *fragments)


@pytest.mark.parametrize(
    "args, fragments",
    [
        (["priors.E_c.a=100", "priors.E_c.b=10"], ["priors.E_c", "lo < hi"]),
        (["priors.E_c.plausible=[60,20]"], ["priors.E_c.plausible", "lower bound 60 is not below upper bound 20"]),
        (["priors.sigma_a.bounds=[5,0]"], ["priors.sigma_a.bounds"]),
    ],
)
def test_inverted_bounds(cli, args: list[str], fragments: list[str]) -> None:
    assert_one_line_error(cli(*args), *fragments)


def test_script_reports_the_same_way(cli) -> None:
    assert_one_line_error(cli("kernel=foo", script=True), "Could not find 'kernel/foo'")


def test_full_error_shows_the_traceback(cli) -> None:
    result = cli("priors.E_c.plausible=[60,20]", env={"HYDRA_FULL_ERROR": "1"})
    assert result.returncode != 0 and "Traceback" in result.stderr


def test_no_run_folder_for_a_config_error(cli, tmp_path: Path) -> None:
    cli("kernel=foo")
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["predict.n=0"], ["predict.n must be >= 1"]),
        (["method=emcee", "method.thin=0"], ["thin (method.thin) must be an integer >= 1"]),
        (["method=emcee", "method.n_walkers=3"], ["n_walkers (method.n_walkers) must be at least twice"]),
    ],
)
def test_method_and_predict_options_checked_before_inference(cli, args: list[str], fragments: list[str]) -> None:
    assert_one_line_error(cli(*args), *fragments)
