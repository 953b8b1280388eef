"""Priors from their config entries (``conf/priors/*.yaml``) to ``torchshm`` prior objects,
and the parameters' display labels (``label``, ``unit``) from the same entries."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields

from torchshm.config.schema import Distribution, PriorConfig
from torchshm.priors import Gamma, Normal, Uniform

#: the fields each family needs and may take (``fixed`` needs ``value`` and ignores the rest)
_REQUIRED: dict[Distribution, tuple[str, ...]] = {
    Distribution.uniform: ("a", "b"),
    Distribution.gamma: ("alpha", "beta"),
    Distribution.normal: ("mean", "sd"),
}
#: fields that only name the parameter in plots and tables
_DISPLAY = ("label", "unit")
_OPTIONAL: dict[Distribution, tuple[str, ...]] = {
    Distribution.uniform: ("plausible",),
    Distribution.gamma: ("bounds", "plausible"),
    Distribution.normal: ("bounds", "plausible"),
}


def build_prior(name: str, entry: PriorConfig) -> object:
    """The prior of one parameter (a ``torchshm`` prior, or a float for ``fixed``).

    A ``fixed`` entry needs ``value`` and ignores its other fields, so that
    ``priors.<name>={dist:fixed,value:35}`` fixes a parameter; the other families accept only
    their own fields (and ``label``, ``unit``), so that a misplaced bound is reported rather
    than ignored.

    Args:
        name: the parameter name, used in error messages (``priors.<name>``).
        entry: its config entry.

    Raises:
        ValueError: ``priors.<name>: ...`` for a missing or superfluous field, a bound that is
            not a pair, inverted bounds or plausible bounds outside the hard ones.
    """
    dist = entry.dist
    if dist is Distribution.fixed:  # the other fields may be left from the prior it replaces
        if entry.value is None:
            raise ValueError(f"priors.{name}: a fixed prior needs value")
        return float(entry.value)
    given = {f.name for f in fields(entry)
             if f.name not in _DISPLAY and f.name != "dist" and getattr(entry, f.name) is not None}
    missing = [k for k in _REQUIRED[dist] if k not in given]
    if missing:
        raise ValueError(f"priors.{name}: a {dist.value} prior needs {', '.join(missing)}")
    extra = sorted(given - set(_REQUIRED[dist]) - set(_OPTIONAL[dist]))
    if extra:
        hint = " (a uniform prior's hard bounds are [a, b])" if "bounds" in extra else ""
        raise ValueError(f"priors.{name}: a {dist.value} prior takes no {', '.join(extra)}{hint}")
    bounds = _pair(name, "bounds", entry.bounds)
    plausible = _pair(name, "plausible", entry.plausible)
    try:
        if dist is Distribution.uniform:
            return Uniform(entry.a, entry.b, plausible=plausible)
        if dist is Distribution.gamma:
            return Gamma(entry.alpha, entry.beta, bounds=bounds, plausible=plausible)
        return Normal(entry.mean, entry.sd, bounds=bounds, plausible=plausible)
    except ValueError as err:
        raise ValueError(f"priors.{name}: {err}") from None


def build_priors(entries: Mapping[str, PriorConfig]) -> dict[str, object]:
    """Every prior of ``entries``, in their order (physical parameters first, by convention).

    Raises:
        ValueError: as :func:`build_prior`, or when ``entries`` is empty.
    """
    if not entries:
        raise ValueError("priors: no parameter has a prior")
    return {name: build_prior(name, entry) for name, entry in entries.items()}


def parameter_labels(entries: Mapping[str, PriorConfig], model: object = None) -> dict[str, str]:
    """Axis label of each parameter: ``"<label> [<unit>]"``, from its priors entry or the model.

    The entry's ``label`` and ``unit`` come first; a model may supply the others through
    optional mappings ``model.labels`` and ``model.units`` (name -> text). A parameter with
    neither is labelled by its name (without a unit).

    Args:
        entries: the priors entries, by parameter name.
        model: the forward model, or ``None``.
    """
    model_labels = getattr(model, "labels", None) or {}
    model_units = getattr(model, "units", None) or {}
    out = {}
    for name, entry in entries.items():
        label = entry.label or model_labels.get(name) or name
        unit = entry.unit or model_units.get(name)
        out[name] = f"{label} [{unit}]" if unit else str(label)
    return out


def _pair(name: str, what: str, values: list[float] | None) -> tuple[float, float] | None:
    """``values`` as a ``(lower, upper)`` pair with lower < upper, or ``None``."""
    if values is None:
        return None
    if len(values) != 2:
        raise ValueError(f"priors.{name}.{what} must be [lower, upper], got {list(values)}")
    lower, upper = float(values[0]), float(values[1])
    if not lower < upper:
        raise ValueError(f"priors.{name}.{what}: lower bound {lower:g} is not below upper bound {upper:g}")
    return lower, upper


__all__ = ["build_prior", "build_priors", "parameter_labels"]
