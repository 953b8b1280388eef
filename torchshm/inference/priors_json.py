"""Priors as JSON-able dicts, so that a saved posterior keeps the priors it was inferred under.

``{"type": "Gamma", "params": {"alpha": 2.0, "beta": 2.0}, "bounds": [0, 5],
"plausible": [0.2, 2.0]}`` for a prior; ``{"fixed": 0.3}`` for a fixed value. Only the
library's own prior classes are rebuilt on reading; any other prior is kept as its ``repr``.
"""

from __future__ import annotations

from typing import Any

#: constructor parameters of each rebuildable prior class
PRIOR_PARAMS: dict[str, tuple[str, ...]] = {
    "Uniform": ("a", "b"),
    "Gamma": ("alpha", "beta"),
    "Normal": ("mean", "sd"),
}


def prior_to_json(prior: Any) -> dict[str, Any]:
    """One prior (or fixed number) as a JSON-able dict."""
    if isinstance(prior, (int, float)):
        return {"fixed": float(prior)}
    kind = type(prior).__name__
    item: dict[str, Any] = {"type": kind, "repr": repr(prior)}
    if kind in PRIOR_PARAMS:
        item["params"] = {p: float(getattr(prior, p)) for p in PRIOR_PARAMS[kind]}
    for key in ("hard_bounds", "plausible_bounds"):
        if hasattr(prior, key):
            item[key] = [float(v) for v in getattr(prior, key)]
    return item


def prior_from_json(item: dict[str, Any]) -> Any:
    """The prior (or number) ``item`` describes; its ``repr`` text for an unknown class."""
    if "fixed" in item:
        return float(item["fixed"])
    kind = item.get("type")
    if kind not in PRIOR_PARAMS or "params" not in item:
        return str(item.get("repr", kind))
    import torchshm.priors as priors

    cls = getattr(priors, kind)
    kwargs: dict[str, Any] = dict(item["params"])
    if "plausible_bounds" in item:
        kwargs["plausible"] = tuple(item["plausible_bounds"])
    if kind != "Uniform" and "hard_bounds" in item:
        kwargs["bounds"] = tuple(item["hard_bounds"])
    return cls(**kwargs)


def priors_to_json(priors: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """A priors dict (name -> prior or number) as JSON-able dicts, order kept."""
    return {str(k): prior_to_json(v) for k, v in priors.items()}


def priors_from_json(items: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Inverse of :func:`priors_to_json`."""
    return {k: prior_from_json(v) for k, v in items.items()}
