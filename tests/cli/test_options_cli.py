"""The options the docs show, through the command line (no inference is run)."""

from __future__ import annotations

from tests.cli.test_bad_input import assert_one_line_error
from torchshm.kernels import kernel_names


def test_help_lists_the_user_groups_only(cli) -> None:
    result = cli("--help")
    assert result.returncode == 0
    groups = result.stdout.split("== Configuration groups ==", 1)[1].split("== Config ==", 1)[0]
    for group in ("executor:", "kernel:", "method:", "model:", "priors:", "resolution:"):
        assert group in groups
    assert "schema" not in groups
    kernels = next(line for line in groups.splitlines() if line.startswith("kernel:"))
    listed = set(kernels.split(":", 1)[1].replace(" ", "").split(","))
    assert listed == set(kernel_names())  # Table 6, separable_exponential and upscaled


def test_executor_joblib_is_selectable(cli) -> None:
    result = cli("executor=joblib", "executor.n_jobs=2", "--cfg", "job")
    assert result.returncode == 0, result.stderr
    assert "kind: joblib" in result.stdout and "n_jobs: 2" in result.stdout


def test_prior_entry_replaced_from_the_command_line(cli) -> None:
    result = cli("priors.E_c={dist:normal,mean:35,sd:5}", "--cfg", "job", "--package", "priors.E_c")
    assert result.returncode == 0, result.stderr
    assert "dist: normal" in result.stdout and "a: 10" not in result.stdout
    # the priors are built and accepted: the next input checked, the data file, is what fails
    assert_one_line_error(cli("priors.E_c={dist:normal,mean:35,sd:5}", "data.path=missing.csv"),
                          "missing.csv")
