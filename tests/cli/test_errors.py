"""One-line messages of Hydra, OmegaConf and library errors."""

from __future__ import annotations

import pytest
from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException
from omegaconf.errors import ValidationError

from torchshm.cli.errors import EXIT_BAD_INPUT, BadInput, bad_input_in_job, one_line, report_bad_input


def test_missing_option_lists_the_options_on_one_line() -> None:
    err = MissingConfigException(
        "In 'config': Could not find 'kernel/foo'\n\nAvailable options in 'kernel':\n\tmatern32\n"
        "\tmatern52\nConfig search path:\n\tprovider=hydra, path=pkg://hydra.conf\n",
        missing_cfg_file="kernel/foo",
    )
    assert one_line(err) == ("In 'config': Could not find 'kernel/foo'; available options in "
                             "'kernel': matern32, matern52")


def test_cause_is_appended() -> None:
    try:
        try:
            raise ValidationError("Invalid value 'foo', expected one of [a, b]\n    full_key: kernel.name")
        except ValidationError as cause:
            raise ConfigCompositionException("Error merging override kernel.name=foo") from cause
    except ConfigCompositionException as err:
        assert one_line(err) == ("Error merging override kernel.name=foo: Invalid value 'foo', "
                                 "expected one of [a, b]")


def test_parse_error_names_the_override() -> None:
    err = OverrideParseException("kernel=[", "no viable alternative at input '['\nSee https://...")
    assert one_line(err) == "cannot parse override 'kernel=[': no viable alternative at input '['"


def test_plain_error_keeps_its_first_line() -> None:
    assert one_line(ValueError("unknown load case 12.3 (measured: 39.8)\nmore")) == (
        "unknown load case 12.3 (measured: 39.8)")
    assert "/x.csv" in one_line(FileNotFoundError(2, "No such file or directory", "/x.csv"))


def test_report_bad_input_prints_one_line_and_exits_2(capsys, monkeypatch) -> None:
    monkeypatch.delenv("HYDRA_FULL_ERROR", raising=False)
    with pytest.raises(SystemExit) as info, report_bad_input("prog"):
        with bad_input_in_job():
            raise ValueError("priors.E_c: bad\nsecond line")
    assert info.value.code == EXIT_BAD_INPUT
    assert capsys.readouterr().err == "prog: error: priors.E_c: bad\n"


def test_full_error_lets_the_exception_through(monkeypatch) -> None:
    monkeypatch.setenv("HYDRA_FULL_ERROR", "1")
    with pytest.raises(BadInput), report_bad_input("prog"), bad_input_in_job():
        raise ValueError("x")


def test_other_errors_are_not_swallowed(monkeypatch) -> None:
    monkeypatch.delenv("HYDRA_FULL_ERROR", raising=False)
    with pytest.raises(ZeroDivisionError), report_bad_input("prog"):
        raise ZeroDivisionError("a bug, not a bad input")
