"""sigma_a and length are scales: zero length and priors with negative support are refused."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from torchshm import Gamma, Normal, Problem, Uniform

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "inference"))
from inference_models import LinearModel, linear_gaussian_problem  # noqa: E402

BASE = {"p0": Normal(0.0, 1.0), "p1": Normal(0.0, 1.0)}


def _problem(kernel: str, **statistical: object) -> Problem:
    data = linear_gaussian_problem().measurements
    return Problem(LinearModel(), data, kernel=kernel, priors={**BASE, **statistical})


@pytest.mark.parametrize("statistical, fragment", [
    ({"sigma_a": 1.0, "length": 0.0}, "fixed length must be > 0"),
    ({"sigma_a": 1.0, "length": -1.0}, "fixed length must be > 0"),
    ({"sigma_a": -0.5, "length": 1.0}, "fixed sigma_a must be >= 0, got -0.5"),
    ({"sigma_a": Normal(1.0, 1.0), "length": 1.0}, "sigma_a is a scale and cannot be negative"),
    ({"sigma_a": 1.0, "length": Uniform(-1.0, 5.0)}, "length is a scale and cannot be negative"),
])
def test_refused_with_one_line_naming_the_parameter(statistical: dict, fragment: str) -> None:
    with pytest.raises(ValueError, match=fragment) as info:
        _problem("matern32", **statistical)
    assert "\n" not in str(info.value)


def test_valid_scales_are_accepted() -> None:
    assert _problem("matern32", sigma_a=0.0, length=Gamma(3.0, 1.0)).names == ["p0", "p1", "length"]
    assert _problem("matern32", sigma_a=Normal(1.0, 1.0, bounds=(0.0, 5.0)), length=2.0).names[-1] == "sigma_a"
    # a kernel without length drops the entry, whatever it is
    assert _problem("independent", sigma_a=1.0, length=0.0).names == ["p0", "p1"]
