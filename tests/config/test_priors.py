"""Priors from the config: Table 2 and 4 by default, user changes checked with named errors."""

from __future__ import annotations

import pytest

import torchshm
from torchshm.config import Distribution, PriorConfig, build_prior, build_priors, to_settings


def test_default_priors_are_tables_2_and_4(compose_cfg) -> None:
    built = build_priors(to_settings(compose_cfg()).priors)
    paper = torchshm.paper_priors()
    assert list(built) == list(paper)
    for name, prior in paper.items():
        assert type(built[name]) is type(prior), name
        assert built[name].hard_bounds == prior.hard_bounds, name
        assert built[name].plausible_bounds == prior.plausible_bounds, name
        assert repr(built[name]) == repr(prior), name


def test_override_changes_a_prior(compose_cfg) -> None:
    cfg = compose_cfg("priors.E_c.a=20", "priors.E_c.b=60", "priors.E_c.plausible=[25,50]")
    prior = build_priors(to_settings(cfg).priors)["E_c"]
    assert prior.hard_bounds == (20.0, 60.0) and prior.plausible_bounds == (25.0, 50.0)


def test_fixed_prior_ignores_the_fields_it_replaces(compose_cfg) -> None:
    cfg = compose_cfg("priors.log10_K_r={dist:fixed,value:11.5}")
    assert build_priors(to_settings(cfg).priors)["log10_K_r"] == 11.5


def test_normal_prior_with_bounds() -> None:
    prior = build_prior("E_c", PriorConfig(Distribution.normal, mean=35.0, sd=5.0, bounds=[10.0, 100.0]))
    assert isinstance(prior, torchshm.Normal) and prior.hard_bounds == (10.0, 100.0)


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["priors.E_c.a=100", "priors.E_c.b=10"], r"priors\.E_c: .*lo < hi"),
        (["priors.E_c.plausible=[60,20]"], r"priors\.E_c\.plausible: lower bound 60 is not below upper bound 20"),
        (["priors.sigma_a.bounds=[5,0]"], r"priors\.sigma_a\.bounds: lower bound 5 is not below"),
        (["priors.E_c.plausible=[5,60]"], r"priors\.E_c: .*outside the hard bounds"),
        (["priors.E_c.plausible=[20]"], r"priors\.E_c\.plausible must be \[lower, upper\]"),
        (["priors.E_c.bounds=[10,100]"], r"priors\.E_c: a uniform prior takes no bounds"),
        (["priors.sigma_a.alpha=null"], r"priors\.sigma_a: a gamma prior needs alpha"),
        (["priors.sigma_a.alpha=-1"], r"priors\.sigma_a: Gamma alpha must be finite and > 0"),
        (["priors.E_c.dist=normal"], r"priors\.E_c: a normal prior needs mean, sd"),
        (["priors.E_c.dist=fixed"], r"priors\.E_c: a fixed prior needs value"),
    ],
)
def test_bad_prior_names_the_problem(compose_cfg, overrides: list[str], message: str) -> None:
    settings = to_settings(compose_cfg(*overrides))
    with pytest.raises(ValueError, match=message):
        build_priors(settings.priors)


def test_empty_priors_rejected() -> None:
    with pytest.raises(ValueError, match="no parameter has a prior"):
        build_priors({})
