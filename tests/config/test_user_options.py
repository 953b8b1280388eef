"""Options the docs show a user: replacing a prior, labels, the executor group, the help."""

from __future__ import annotations

import pytest

from torchshm.config import (
    Distribution,
    PriorConfig,
    build_priors,
    normalize_overrides,
    parameter_labels,
    replace_prior_override,
    to_settings,
)


def settings(compose_cfg, *overrides: str):
    return to_settings(compose_cfg(*normalize_overrides(list(overrides))))


def test_prior_entry_is_replaced_not_merged(compose_cfg) -> None:
    s = settings(compose_cfg, "priors.E_c={dist:normal,mean:35,sd:5}")
    e = s.priors["E_c"]
    assert (e.dist.value, e.mean, e.sd) == ("normal", 35.0, 5.0)
    assert e.a is None and e.b is None and e.plausible is None  # nothing left of the uniform prior
    assert e.label == "$E_c$" and e.unit == "GPa"  # display fields stay unless given
    prior = build_priors(s.priors)["E_c"]
    assert type(prior).__name__ == "Normal"


def test_replacing_entry_with_bounds_and_label(compose_cfg) -> None:
    s = settings(compose_cfg, "priors.sigma_a={dist:uniform,a:0,b:4,plausible:[0.5,2],label:'s a'}")
    e = s.priors["sigma_a"]
    assert (e.a, e.b, e.plausible, e.alpha, e.beta, e.bounds) == (0.0, 4.0, [0.5, 2.0], None, None, None)
    assert e.label == "s a"


def test_replace_rewrites_only_whole_prior_entries() -> None:
    for item in ["priors.E_c.a=20", "kernel=matern52", "+priors.new={dist:fixed,value:1}",
                 "priors={a:1}", "data.loads=[1,2]"]:
        assert replace_prior_override(item) == item
    sweep = replace_prior_override("priors.E_c={dist:fixed,value:30},{dist:normal,mean:35,sd:5}")
    assert sweep.count("{") == 2 and sweep.count(",b:null,") == 2


def test_fixed_prior_from_the_command_line(compose_cfg) -> None:
    s = settings(compose_cfg, "priors.log10_K_r={dist:fixed,value:11.5}")
    assert build_priors(s.priors)["log10_K_r"] == 11.5


def test_labels_come_from_the_priors_then_the_model() -> None:
    class Model:
        units = {"k": "N/m"}
        labels = {"k": "stiffness"}

    entries = {"E": PriorConfig(label="$E$", unit="GPa"), "k": PriorConfig(),
               "sigma_a": PriorConfig(unit="µε"), "length": PriorConfig()}
    assert parameter_labels(entries, Model()) == {
        "E": "$E$ [GPa]", "k": "stiffness [N/m]", "sigma_a": "sigma_a [µε]", "length": "length"}


def test_label_and_unit_are_not_distribution_fields() -> None:
    prior = build_priors({"E": PriorConfig(dist=Distribution.uniform, a=1, b=2, label="E", unit="GPa")})["E"]
    assert prior.hard_bounds == (1.0, 2.0)


@pytest.mark.parametrize("option", ["serial", "joblib", "dask", "local", "slurm"])
def test_executor_group_is_selectable(compose_cfg, option: str) -> None:
    s = settings(compose_cfg, f"executor={option}")
    assert s.executor.kind == option


def test_executor_options(compose_cfg) -> None:
    s = settings(compose_cfg, "executor=joblib", "executor.n_jobs=2")
    assert (s.executor.kind, s.executor.n_jobs) == ("joblib", 2)


@pytest.mark.parametrize("override", [
    "kernel=matern52", "method=emcee", "model=fe", "resolution=0.5", "priors=paper",
    "data.loads=[39.8,47.5]", "seed=3", "predict.loads=[]", "store=runs/evals.sqlite",
    "method=emcee", "likelihood.sigma_m=0.1", "priors.E_c.a=20",
])
def test_every_documented_override_composes(compose_cfg, override: str) -> None:
    settings(compose_cfg, override)
