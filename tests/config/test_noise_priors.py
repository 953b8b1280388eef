"""A prior entry for likelihood.sigma_m / sigma_e in the config makes the noise level inferred."""

from __future__ import annotations

from pathlib import Path

import torchshm
from torchshm.cli.job import build_problem
from torchshm.config import to_settings


def test_a_noise_prior_in_the_config_infers_it(compose_cfg) -> None:
    settings = to_settings(compose_cfg("likelihood.sigma_m={dist:uniform,a:0,b:0.2}",
                                       "likelihood.sigma_e={dist:gamma,alpha:2,beta:10}"))
    problem = build_problem(settings, torchshm.bridge705_surrogate(), torchshm.synthetic_campaign(0),
                            Path("."))
    assert problem.names == ["E_c", "log10_K_r", "sigma_a", "length", "sigma_m", "sigma_e"]
    assert problem.search_bounds[-1, 1] < 10.0  # the one-sided Gamma of sigma_e gets a closed box


def test_a_noise_level_that_is_neither_number_nor_prior_is_refused(compose_cfg) -> None:
    import pytest

    settings = to_settings(compose_cfg("likelihood.sigma_m=large"))
    with pytest.raises(ValueError, match="likelihood.sigma_m must be a number or a prior"):
        build_problem(settings, torchshm.bridge705_surrogate(), torchshm.synthetic_campaign(0), Path("."))
