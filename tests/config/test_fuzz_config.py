"""Fuzz: prior entries of the config, composed as a user would override them on the command
line, build usable priors or end in one line (``priors.<name>`` named for a bad value)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

FUZZ = settings(max_examples=15, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def _usable(prior) -> None:
    lo, hi = prior.hard_bounds
    p_lo, p_hi = prior.plausible_bounds
    assert lo < hi and lo <= p_lo < p_hi <= hi and math.isfinite(p_lo) and math.isfinite(p_hi)
    draws = prior.sample(50, np.random.default_rng(0))
    assert np.all((draws >= lo) & (draws <= hi)) and np.isfinite(draws).all()


DIST = st.sampled_from(["uniform", "gamma", "normal", "fixed", "cauchy", "''", "1", "null"])
KEYS = st.sampled_from(["a", "b", "alpha", "beta", "mean", "sd", "value", "bounds", "plausible", "shape"])
ITEM = st.one_of(st.sampled_from(["0", "-1", "1e400", "-inf", "inf", "nan", "abc", "[1,0]", "[0,10]",
                                  "[-5,5]", "[1]", "[a,b]", "{x:1}", "null", "true", "2", "5.5", "35"]))


@FUZZ
@given(name=st.sampled_from(["E_c", "sigma_a", "length", "new_param"]), dist=DIST,
       fields=st.dictionaries(KEYS, ITEM, max_size=4))
def test_fuzzed_config_priors(compose_cfg, name: str, dist: str, fields: dict[str, str]) -> None:
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    from torchshm.cli.errors import one_line
    from torchshm.config import build_priors, to_settings

    entry = ",".join([f"dist:{dist}", *(f"{k}:{v}" for k, v in fields.items())])
    override = f"priors.{name}={{{entry}}}" if name != "new_param" else f"+priors.{name}={{{entry}}}"
    try:
        priors = build_priors(to_settings(compose_cfg(override)).priors)
    except (ValueError, TypeError, HydraException, OmegaConfBaseException) as err:
        line = one_line(err)
        assert line and "\n" not in line
        if isinstance(err, (ValueError, TypeError)):
            assert "priors" in line, line
        return
    for prior in priors.values():
        if not isinstance(prior, float):
            _usable(prior)
        else:
            assert math.isfinite(prior)
