"""The joint prior of the inferred parameters: independent priors, one per column.

One object gives the log density and the draws that :class:`~torchshm.problem.Problem`,
:class:`~torchshm.inference.Posterior` and :func:`~torchshm.predictive.kl_divergence` use, so
the prior of a run is evaluated the same way wherever it is needed.

A prior may be bounded on one side only (``Gamma(2, 2)`` without ``bounds``: ``(0, inf)``).
PyVBMC needs every parameter bounded on both sides or on neither, so the methods search the
box :attr:`JointPrior.search_bounds`: the hard bounds with each open end of a one-sided prior
closed at its ``1 - 1e-12`` quantile (:data:`TAIL_MASS` of prior mass is left out, a change of
the log evidence by ~1e-12 nats). A user prior with only ``log_prob`` and ``hard_bounds`` gets
its open end from a scan of its log density (where it has fallen by :data:`TAIL_DROP` nats).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import torch
from torch import Tensor

from torchshm.arrays import as_float64

#: prior mass left beyond each open end of a one-sided prior by :attr:`JointPrior.search_bounds`
TAIL_MASS = 1e-12
#: drop of the log density [nats] that closes an open end of a prior without quantiles
TAIL_DROP = 40.0
#: quantiles of a plausible box derived from draws (the central 68.27 %)
PLAUSIBLE_Q = (0.15865525393145707, 0.8413447460685429)


class JointPrior:
    """Product of independent priors over the columns of a parameter vector `D`.

    Args:
        priors: name -> prior (an object with ``log_prob``; ``sample``, ``hard_bounds`` and
            ``plausible_bounds`` too for the methods that use them) or a number (fixed).
        names: the `D` inferred parameters, in column order; each must have a prior.

    Raises:
        ValueError: naming a parameter that is missing from ``priors`` or whose prior has no
            ``log_prob``.
    """

    def __init__(self, priors: Mapping[str, object], names: Sequence[str]) -> None:
        self.names = [str(n) for n in names]
        for name in self.names:
            if name not in priors:
                raise ValueError(f"prior: no prior for the inferred parameter {name!r}")
            if not hasattr(priors[name], "log_prob"):
                raise ValueError(
                    f"prior: parameter {name!r} is inferred but its prior {priors[name]!r} "
                    "has no log_prob"
                )
        self.components = [priors[n] for n in self.names]

    @property
    def dim(self) -> int:
        """Number of inferred parameters `D`."""
        return len(self.names)

    def log_prob(self, theta: object) -> Tensor | np.ndarray:
        """Log density `...` of ``theta`` (`... x D`), numpy in numpy out, torch in torch out.

        -inf (never NaN) outside the support. Differentiable for a tensor ``theta``.
        """
        t = as_float64(theta)
        if t.ndim == 0 or t.shape[-1] != self.dim:
            raise ValueError(
                f"theta must have shape (..., {self.dim}) for {self.names}, got {tuple(t.shape)}"
            )
        total = t.new_zeros(t.shape[:-1])
        for k, prior in enumerate(self.components):
            total = total + as_float64(prior.log_prob(t[..., k]))  # type: ignore[attr-defined]
        total = torch.where(torch.isnan(total), -torch.inf, total)
        return total if isinstance(theta, Tensor) else total.detach().numpy()[()]

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """`n x D` independent draws (each prior's ``sample(n, rng)``, in column order).

        A prior without ``sample`` is drawn uniformly from its plausible box (a starting
        spread for the samplers, not its distribution)."""
        rng = np.random.default_rng(rng)
        cols = []
        for k, prior in enumerate(self.components):
            if hasattr(prior, "sample"):
                cols.append(np.asarray(prior.sample(n, rng), dtype=np.float64))
            else:
                lo, hi = self.plausible_bounds[k]
                cols.append(rng.uniform(lo, hi, size=int(n)))
        return np.column_stack(cols) if cols else np.zeros((int(n), 0))

    @property
    def hard_bounds(self) -> np.ndarray:
        """`D x 2` hard bounds (outside them the density is zero)."""
        return np.array([_hard(p) for p in self.components], dtype=np.float64).reshape(-1, 2)

    @property
    def search_bounds(self) -> np.ndarray:
        """`D x 2` hard bounds with the open end of each one-sided prior closed (module doc):
        bounded on both sides or on neither, as PyVBMC requires."""
        out = self.hard_bounds.copy()
        for k, prior in enumerate(self.components):
            lo, hi = out[k]
            if np.isfinite(lo) != np.isfinite(hi):
                out[k] = _closed(prior, lo, hi)
        return out

    @property
    def plausible_bounds(self) -> np.ndarray:
        """`D x 2` plausible bounds (where most of the prior mass lies); for a prior without
        them, the central 68 % of its draws, or of its search box when it cannot draw."""
        rows = []
        for prior in self.components:
            given = getattr(prior, "plausible_bounds", None)
            rows.append(given if given is not None else _plausible(prior))
        return np.array(rows, dtype=np.float64).reshape(-1, 2)

    def __repr__(self) -> str:
        return f"JointPrior({dict(zip(self.names, self.components))!r})"


def _hard(prior: object) -> tuple[float, float]:
    bounds = getattr(prior, "hard_bounds", None)
    return (-np.inf, np.inf) if bounds is None else (float(bounds[0]), float(bounds[1]))


def _closed(prior: object, lo: float, hi: float) -> tuple[float, float]:
    """``(lo, hi)`` of a one-sided prior with its open end at the ``TAIL_MASS`` quantile, or,
    without ``ppf``, where the log density has dropped ``TAIL_DROP`` nats below its peak
    along a geometric scan outward from the finite end."""
    upper = not np.isfinite(hi)
    if hasattr(prior, "ppf"):
        end = float(np.asarray(prior.ppf(np.array([1.0 - TAIL_MASS if upper else TAIL_MASS])))[0])
        if np.isfinite(end):
            return (lo, end) if upper else (end, hi)
    edge = lo if upper else hi
    sign = 1.0 if upper else -1.0
    steps = edge + sign * np.ldexp(1.0, np.arange(-20, 60)) * max(1.0, abs(edge))
    values = np.asarray(prior.log_prob(steps), dtype=np.float64)  # type: ignore[attr-defined]
    finite = np.isfinite(values)
    peak = values[finite].max() if finite.any() else 0.0
    below = np.flatnonzero(finite & (values < peak - TAIL_DROP)
                           & (np.arange(values.size) > np.argmax(np.where(finite, values, -np.inf))))
    end = float(steps[below[0]] if below.size else steps[-1])
    return (lo, end) if upper else (end, hi)


def _plausible(prior: object) -> tuple[float, float]:
    if hasattr(prior, "sample"):
        draws = np.asarray(prior.sample(4000, np.random.default_rng(0)), dtype=np.float64)
        lo, hi = np.quantile(draws, PLAUSIBLE_Q)
        return float(lo), float(hi)
    lo, hi = _hard(prior)
    if np.isfinite(lo) != np.isfinite(hi):
        lo, hi = _closed(prior, lo, hi)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"prior {prior!r}: give plausible_bounds (it has no sample and no "
                         "finite hard bounds to derive them from)")
    return lo + PLAUSIBLE_Q[0] * (hi - lo), lo + PLAUSIBLE_Q[1] * (hi - lo)
