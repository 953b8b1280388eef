"""The schemas reject what they do not describe: wrong types, unknown keys, unknown options."""

from __future__ import annotations

import pytest
from hydra.errors import ConfigCompositionException, MissingConfigException

from torchshm.config import to_settings


@pytest.mark.parametrize(
    "override, fragment",
    [
        ("seed=x", "Integer"),
        ("seed=1.5", "Integer"),
        ("data.loads=5", "ListConfig"),
        ("data.loads=[39.8,a]", "Float"),
        ("kernel.name=foo", "expected one of"),
        ("executor.n_jobs=many", "Integer"),
        ("priors.E_c.dist=lognormal", "expected one of"),
        ("priors.E_c.a=low", "Float"),
        ("method.max_model_evaluations=many", "Integer"),
    ],
)
def test_wrong_type_or_value_is_rejected(compose_cfg, override: str, fragment: str) -> None:
    with pytest.raises(ConfigCompositionException) as info:
        compose_cfg(override)
    assert fragment in str(info.value.__cause__)


@pytest.mark.parametrize("override", ["bogus=1", "data.bogus=1", "method.n_samples=8"])
def test_unknown_key_is_rejected_by_hydra(compose_cfg, override: str) -> None:
    with pytest.raises(ConfigCompositionException, match="Could not override"):
        compose_cfg(override)


@pytest.mark.parametrize("override, key", [("+bogus=1", "bogus"), ("+data.bogus=1", "data.bogus"),
                                           ("+method.foo=2", "method.foo"),
                                           ("+priors.E_c.shape=2", "priors.E_c.shape")])
def test_appended_unknown_key_is_rejected_by_to_settings(compose_cfg, override: str, key: str) -> None:
    cfg = compose_cfg(override)  # Hydra lets '+' add keys even to a structured config
    with pytest.raises(ValueError, match=f"unknown key '{key}'"):
        to_settings(cfg)


@pytest.mark.parametrize("override", ["kernel=foo", "method=nuts", "model=abaqus", "resolution='0.3'",
                                      "priors=mine"])
def test_unknown_group_option_is_rejected(compose_cfg, override: str) -> None:
    with pytest.raises(MissingConfigException, match="Could not find"):
        compose_cfg(override)
