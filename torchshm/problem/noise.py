"""The noise levels of a :class:`~torchshm.Problem` (σm, σe) and its default priors.

σm (multiplicative model error) and σe [µε] (measurement noise) are each either fixed or
inferred: a prior given as the ``sigma_m`` / ``sigma_e`` argument or as a ``priors`` entry
makes the level a parameter (after the discrepancy's). A fixed σe is one number, or one per
line when the measurements give one per line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from torchshm.priors import Prior
from torchshm.problem.parameters import NOISE


def default_priors(model: Any) -> Mapping[str, Prior | float]:
    """``model.default_priors()``: the priors of ``Problem(priors=None)``.

    Raises:
        ValueError: when the model declares none.
    """
    make = getattr(model, "default_priors", None)
    if make is None:
        raise ValueError(f"Problem: {type(model).__name__} declares no default_priors(); give priors= "
                         "(name -> Prior or number: the physical parameters, sigma_a, length)")
    return make()


@dataclass
class NoiseLevels:
    """σm and σe of a problem, fixed or inferred.

    Attributes:
        sigma_m: the fixed σm (>= 0) or its prior.
        sigma_e: the fixed σe [µε] (a number, or line label -> number), or its prior.
        base: the σe the likelihood blocks hold: the fixed one, or 1 when σe is inferred (the
            blocks are then scaled by the inferred value).
        priors: name -> checked prior or fixed value, for the noise entries that were given.
    """

    sigma_m: float | Any
    sigma_e: float | dict | Any
    base: float | dict
    priors: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def read(cls, given: dict[str, Any], sigma_m: Any, sigma_e: Any, measurements: Any,
             lines: list) -> NoiseLevels:
        """The levels from the ``Problem`` arguments; the ``sigma_m`` / ``sigma_e`` entries of
        ``given`` (the priors dict) are taken out of it.

        Raises:
            ValueError: for a negative or non-finite level, or a prior allowing negative values.
        """
        noise_priors = {n: given.pop(n) for n in NOISE if n in given}
        if hasattr(sigma_m, "log_prob"):
            noise_priors["sigma_m"] = sigma_m
        if hasattr(sigma_e, "log_prob"):
            noise_priors["sigma_e"] = sigma_e
        level_m = noise_priors.get("sigma_m", sigma_m)
        if not hasattr(level_m, "log_prob"):
            level_m = _scale("sigma_m", level_m)
        if hasattr(noise_priors.get("sigma_e"), "log_prob"):
            level_e, base = noise_priors["sigma_e"], 1.0  # blocks scaled by the inferred σe
        else:
            level_e = base = _noise(measurements, lines, noise_priors.get("sigma_e", sigma_e))
        checked = {name: _noise_prior(name, prior) for name, prior in noise_priors.items()}
        return cls(level_m, level_e, base, checked)


def _noise(measurements: Any, lines: list, sigma_e: float | None) -> float | dict:
    """The noise level [µε]: one number, or line label -> number when the data give one per line."""
    if sigma_e is not None:
        return _scale("sigma_e", sigma_e)
    given = measurements.sigma_e
    if isinstance(given, Mapping):
        return {label: _scale(f"sigma_e of line {label!r}", given[label]) for label in lines}
    return _scale("sigma_e", given)


def _noise_prior(name: str, prior: object) -> object:
    """A noise level's prior, checked: a prior (``log_prob``) with hard bounds within [0, inf)."""
    if not hasattr(prior, "log_prob"):
        return _scale(name, prior)
    lo = getattr(prior, "hard_bounds", (0.0, math.inf))[0]
    if lo < 0:
        raise ValueError(f"Problem: the prior of {name} {prior!r} allows negative values (hard "
                         f"bounds {tuple(prior.hard_bounds)}); give bounds with a lower bound >= 0")
    return prior


def _scale(name: str, value: object) -> float:
    value = float(value)  # type: ignore[arg-type]
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"Problem: {name} must be finite and >= 0, got {value}")
    return value
