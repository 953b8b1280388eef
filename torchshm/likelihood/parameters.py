"""How a :class:`~torchshm.likelihood.problem.Problem` reads its priors and its data.

- which entries of a priors dict are inferred, fixed, physical or statistical;
- which rows and columns of the model output are the measured load cases and positions;
- the canonical key of a physical parameter vector (12 significant digits), shared with the
  evaluation store, under which model outputs are cached.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence

import numpy as np

from torchshm.data.measurements import POSITION_TOL as MATCH_TOL

from torchshm.kernels import Kernel
from torchshm.priors import Prior

#: the statistical parameters, in the order they follow the physical ones
STATISTICAL = ("sigma_a", "length")
#: significant digits of a canonical parameter value
SIGNIFICANT_DIGITS = 12


def read_priors(
    priors: Mapping[str, object], kernel: Kernel, model_names: Sequence[str] | None
) -> tuple[dict[str, Prior | float], list[str]]:
    """Validated priors and the physical parameter names, in the order the model takes them.

    Args:
        priors: name -> :class:`Prior` or a plain number (a fixed value).
        kernel: the discrepancy kernel; a ``length`` entry is dropped when it has no length.
        model_names: the model's parameter names (``model.names``) when it declares them;
            the physical names then follow the model's order.

    Returns:
        ``(priors, physical_names)``.

    Raises:
        ValueError: naming the entry, for a value that is neither a prior nor a finite number,
            a missing ``sigma_a`` (or ``length``), a negative fixed ``sigma_a`` or ``length``, a
            name the model does not take, or a model parameter without prior.
    """
    out: dict[str, Prior | float] = {}
    for name, value in priors.items():
        if name == "length" and not kernel.has_length:
            continue
        out[str(name)] = _prior_or_value(str(name), value)
    for name in STATISTICAL[: 2 if kernel.has_length else 1]:
        if name not in out:
            raise ValueError(f"priors: no entry for {name!r}, needed by kernel {kernel.name!r}")
        if not isinstance(out[name], Prior) and out[name] < 0:  # type: ignore[operator]
            raise ValueError(f"priors: fixed {name} must be >= 0, got {out[name]}")
    physical = [name for name in out if name not in STATISTICAL]
    if model_names is not None:
        model_names = [str(n) for n in model_names]
        unknown = [n for n in physical if n not in model_names]
        if unknown:
            raise ValueError(
                f"priors: unknown parameter(s) {unknown}; the model takes {model_names} "
                f"({len(model_names)} physical parameters) plus {list(STATISTICAL)}"
            )
        missing = [n for n in model_names if n not in physical]
        if missing:
            raise ValueError(f"priors: no prior or fixed value for model parameter(s) {missing}")
        physical = model_names
    if not physical:
        raise ValueError("priors: no physical parameter (every entry is sigma_a or length)")
    return out, physical


def _prior_or_value(name: str, value: object) -> Prior | float:
    """``value`` if a prior, else a finite float; ``ValueError`` naming ``name`` otherwise."""
    if isinstance(value, Prior):
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    raise ValueError(f"priors: entry {name!r} must be a Prior or a finite number, got {value!r}")


def match_positions(wanted: np.ndarray, available: np.ndarray, what: str) -> np.ndarray:
    """Indices into ``available`` of the values ``wanted``, matched within :data:`MATCH_TOL`.

    Args:
        wanted: `k` values (measured load cases or positions [m]).
        available: `m` values the model produces.
        what: their name in error messages (``"load case"``, ``"position"``).

    Returns:
        `k` integer indices.

    Raises:
        ValueError: naming the values the model does not produce.
    """
    wanted = np.asarray(wanted, dtype=np.float64).ravel()
    available = np.asarray(available, dtype=np.float64).ravel()
    if available.size == 0:
        raise ValueError(f"the model produces no {what}s")
    order = np.argsort(available, kind="stable")
    ordered = available[order]
    right = np.searchsorted(ordered, wanted).clip(0, ordered.size - 1)
    left = (right - 1).clip(0, ordered.size - 1)
    nearest = np.where(
        np.abs(ordered[left] - wanted) <= np.abs(ordered[right] - wanted), left, right
    )
    missing = wanted[np.abs(ordered[nearest] - wanted) > MATCH_TOL]
    if missing.size:
        shown = ", ".join(f"{v:g}" for v in missing[:5]) + (", ..." if missing.size > 5 else "")
        raise ValueError(
            f"measured {what}s not produced by the model (tolerance {MATCH_TOL:g} m): {shown}; "
            f"the model has {available.size} {what}s from {ordered[0]:g} to {ordered[-1]:g}"
        )
    return order[nearest]


def canonical_key(theta_p: np.ndarray) -> tuple[float, ...]:
    """Cache key of one physical parameter vector `P`: values rounded to 12 significant digits."""
    fmt = f"{{:.{SIGNIFICANT_DIGITS - 1}e}}"
    return tuple(float(fmt.format(float(v))) + 0.0 for v in theta_p)
