"""How a :class:`~torchshm.problem.Problem` reads its priors and splits its parameters.

Which entries of a priors dict are inferred or fixed, physical or statistical, in which order
the physical ones are passed to the forward model (:func:`read_priors`), and how a parameter
vector splits into the model's and the discrepancy's parameters (:class:`ParameterSplit`).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.arrays import as_float64
from torchshm.priors import Prior

#: the statistical parameters, in the order they follow the physical ones
STATISTICAL = ("sigma_a", "length")
#: noise levels of Eq. (21) that may be inferred (given a prior), after the statistical ones:
#: ``sigma_m`` (multiplicative model error) and ``sigma_e`` [µε] (measurement noise, one level
#: for every sensor line)
NOISE = ("sigma_m", "sigma_e")


def read_priors(
    priors: Mapping[str, object],
    kernel: Kernel,
    model_names: Sequence[str] | None,
    groups: Sequence[object] = (),
) -> tuple[dict[str, Prior | float], list[str]]:
    """Validated priors and the physical parameter names, in the order the model takes them.

    Args:
        priors: name -> :class:`Prior` or a plain number (a fixed value).
        kernel: the discrepancy kernel; a ``length`` entry is dropped when it has no length.
        model_names: the model's parameter names (``model.names``) when it declares them;
            the physical names then follow the model's order.
        groups: line labels with their own discrepancy parameters (``sigma_a[top]``,
            ``length[top]``...); empty: one ``sigma_a`` [, ``length``] shared by every line. An
            entry ``sigma_a[top]`` falls back on ``sigma_a`` when not given.

    Returns:
        ``(priors, physical_names)``.

    Raises:
        ValueError: naming the entry, for a value that is neither a prior nor a finite number,
            a missing ``sigma_a`` (or ``length``), a negative fixed ``sigma_a`` or ``length`` (or a
            ``length`` of 0), a prior of either whose hard bounds include negative values, a
            name the model does not take, or a model parameter without prior.
    """
    out: dict[str, Prior | float] = {}
    for name, value in priors.items():
        if statistical_base(str(name)) == "length" and not kernel.has_length:
            continue
        out[str(name)] = _prior_or_value(str(name), value)
    bases = STATISTICAL[: 2 if kernel.has_length else 1]
    for base in bases:
        for name in [base] if not groups else [grouped_name(base, g) for g in groups]:
            if name not in out and base in out:
                out[name] = out[base]
            if name not in out:
                raise ValueError(f"priors: no entry for {name!r}, needed by kernel {kernel.name!r}")
            _check_scale(name, out[name])
        if groups:
            out.pop(base, None)
    wanted = {grouped_name(b, g) for b in bases for g in groups} if groups else set(bases)
    stray = [n for n in out if statistical_base(n) is not None and n not in wanted]
    if stray:
        lines = f"lines {list(groups)}" if groups else "one shared pair (discrepancy='shared')"
        raise ValueError(f"priors: entry {stray[0]!r} does not fit the discrepancy parameters of {lines}")
    physical = [name for name in out if statistical_base(name) is None]
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


def grouped_name(base: str, group: object) -> str:
    """``sigma_a[top]``: the parameter ``base`` of line ``group``."""
    return f"{base}[{group}]"


def statistical_base(name: str) -> str | None:
    """``"sigma_a"`` or ``"length"`` for that parameter, shared or of one line (``sigma_a[top]``);
    ``None`` for a physical parameter."""
    base = name.split("[", 1)[0] if name.endswith("]") else name
    return base if base in STATISTICAL else None


def _check_scale(name: str, value: Prior | float) -> None:
    """``sigma_a`` [µε] and ``length`` [m] are scales: a fixed value must be >= 0 (``length``
    > 0: a length of 0 would turn the kernel into the independent one) and a prior's hard bounds
    must exclude negative values (else evaluations are spent where the likelihood is undefined)."""
    if hasattr(value, "log_prob"):
        lo = value.hard_bounds[0]  # type: ignore[union-attr]
        if lo < 0:
            raise ValueError(
                f"priors: {name} is a scale and cannot be negative, but its prior {value!r} has "
                f"hard bounds {tuple(value.hard_bounds)}; give bounds with a lower bound >= 0"
            )
    elif value < 0 or (name == "length" and value == 0):
        rule = "> 0 (use the independent kernel for no correlation)" if name == "length" else ">= 0"
        raise ValueError(f"priors: fixed {name} must be {rule}, got {value}")


def _prior_or_value(name: str, value: object) -> Prior | float:
    """``value`` if a prior, else a finite float; ``ValueError`` naming ``name`` otherwise."""
    if isinstance(value, Prior) or (hasattr(value, "log_prob") and hasattr(value, "hard_bounds")):
        return value  # a prior of the library, or a user's with log_prob and hard_bounds
    if isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    raise ValueError(f"priors: entry {name!r} must be a Prior or a finite number, got {value!r}")


@dataclass(frozen=True)
class ParameterSplit:
    """How a parameter vector `D` splits into the model's and the discrepancy's parameters.

    Attributes:
        names: the `D` inferred parameters, in the column order of ``theta``.
        physical_names: the `P` physical parameters in the order the model takes them (fixed
            ones included).
        fixed: name -> value of every fixed parameter (physical or statistical).
        has_length: whether the discrepancy kernel has a length scale.
        groups: line labels with their own (σa, l), in column order; empty: one shared pair.
    """

    names: tuple[str, ...]
    physical_names: tuple[str, ...]
    fixed: Mapping[str, float]
    has_length: bool
    groups: tuple[object, ...] = ()

    @classmethod
    def from_priors(
        cls, priors: Mapping[str, object], physical_names: Sequence[str], has_length: bool,
        groups: Sequence[object] = (),
    ) -> ParameterSplit:
        """The split of validated priors (see :func:`read_priors`): entries that are numbers
        are fixed, the others inferred (physical first, then ``sigma_a`` and ``length``, line
        by line with ``groups``, then the noise levels of :data:`NOISE` that have a prior)."""
        fixed = {n: float(v) for n, v in priors.items() if _is_number(v)}  # type: ignore[arg-type]
        split = cls((), tuple(physical_names), fixed, has_length, tuple(groups))
        names = [n for n in physical_names if n not in fixed]
        names += [n for n in split.statistical_names if n in priors and n not in fixed]
        names += [n for n in NOISE if n in priors and n not in fixed]
        return dataclasses.replace(split, names=tuple(names))

    def noise(self, theta: object, name: str, fixed: float) -> float | Tensor:
        """``name``'s value (:data:`NOISE`) for rows `B x D`: a `B` tensor when it is inferred,
        else ``fixed``."""
        return self.column(theta, name) if name in self.names else fixed

    @property
    def statistical_names(self) -> tuple[str, ...]:
        """The discrepancy's parameters, inferred or fixed: ``sigma_a`` [, ``length``], or
        ``sigma_a[g]`` [, ``length[g]``] for each group ``g``."""
        bases = STATISTICAL[: 2 if self.has_length else 1]
        if not self.groups:
            return bases
        return tuple(grouped_name(b, g) for g in self.groups for b in bases)

    def column(self, theta: object, name: str) -> Tensor:
        """Values `B` of parameter ``name`` (inferred or fixed) for parameter vectors `B x D`.

        Raises:
            ValueError: if ``name`` is neither inferred nor fixed.
        """
        rows = as_float64(theta)
        if name in self.names:
            return rows[:, self.names.index(name)]
        if name in self.fixed:
            return rows.new_full((rows.shape[0],), self.fixed[name])
        raise ValueError(f"parameter {name!r} is neither inferred nor fixed to a number")

    def physical(self, theta: object) -> Tensor:
        """Physical parameter vectors `B x P` (fixed values filled in) of rows `B x D`."""
        rows = as_float64(theta)
        return torch.stack([self.column(rows, n) for n in self.physical_names], dim=-1)

    def split(self, theta: object) -> tuple[Tensor, Tensor, Tensor | None]:
        """``(theta_p `B x P`, sigma_a `B` [µε], length `B` [m] or None)`` of rows `B x D`.

        ``length`` is ``None`` for a kernel without length; with :attr:`groups`, ``sigma_a``
        and ``length`` are `B x G`, one column per group. Differentiable in ``theta``.
        """
        rows = as_float64(theta)
        if self.groups:
            sigma_a, length = self.discrepancy(rows)
            return self.physical(rows), sigma_a, length
        length = self.column(rows, "length") if self.has_length else None
        return self.physical(rows), self.column(rows, "sigma_a"), length

    def discrepancy(self, theta: object) -> tuple[Tensor, Tensor | None]:
        """``(sigma_a `B x G` [µε], length `B x G` [m] or None)`` of rows `B x D`: one column
        per group (`G` = 1 without groups)."""
        rows = as_float64(theta)
        groups = self.groups or (None,)

        def columns(base: str) -> Tensor:
            names = [base if g is None else grouped_name(base, g) for g in groups]
            return torch.stack([self.column(rows, n) for n in names], dim=-1)

        return columns("sigma_a"), columns("length") if self.has_length else None


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)
