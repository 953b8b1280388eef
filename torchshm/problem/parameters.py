"""How a :class:`~torchshm.problem.Problem` reads its priors.

Which entries of a priors dict are inferred or fixed, physical or statistical, and in which
order the physical ones are passed to the forward model.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence

from torchshm.kernels import Kernel
from torchshm.priors import Prior

#: the statistical parameters, in the order they follow the physical ones
STATISTICAL = ("sigma_a", "length")


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
