"""Convergence measures of study A (paper, Sec. 4, Figs. 5 and 6).

- :func:`window_stats`: mean and 95 % interval of the last ``window`` samples of an ensemble
  chain after each step, as in the paper's Fig. 5 (the last 1,000 samples);
- :func:`half_chain_means`: after each step, the mean of the latest half of the chain (the
  first half is discarded as burn-in, as the final emcee posterior does);
- :func:`stabilisation_point`: the number of samples (or evaluations) from which a sequence of
  estimates stays within ``tol`` posterior standard deviations of the final estimate, for
  every parameter;
- :func:`compare_marginals`: the Table 5 comparison of two posteriors.

"Stabilised" is defined as :func:`stabilisation_point` of :func:`half_chain_means` for emcee
and of the per-iteration variational means for VBMC, both with ``tol = 0.1`` by default. The
windowed mean of Fig. 5 is not used for it: 1,000 correlated samples carry Monte Carlo noise of
about 0.2 posterior sd, so a 0.1 sd criterion on it would measure noise, not convergence.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np


def window_stats(chain: np.ndarray, window: int = 1000) -> tuple[np.ndarray, ...]:
    """Mean and 95 % interval of the last ``window`` samples after each step.

    Args:
        chain: `S x W x D` ensemble chain (steps, walkers, parameters).
        window: samples (steps x walkers) behind each estimate; whole steps are used, at least
            one.

    Returns:
        ``(n_samples, mean, lower, upper)``: `S` sample counts (``step * W``) and `S x D` arrays.
    """
    chain = np.asarray(chain, dtype=np.float64)
    steps, walkers, dim = chain.shape
    k = max(1, -(-int(window) // walkers))
    mean = np.empty((steps, dim))
    lower = np.empty((steps, dim))
    upper = np.empty((steps, dim))
    for s in range(steps):
        block = chain[max(0, s + 1 - k) : s + 1].reshape(-1, dim)
        mean[s] = block.mean(axis=0)
        lower[s], upper[s] = np.quantile(block, (0.025, 0.975), axis=0)
    return np.arange(1, steps + 1) * walkers, mean, lower, upper


def half_chain_means(chain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """After each step `s`, the mean of steps ``s // 2 .. s`` (all walkers).

    Args:
        chain: `S x W x D` ensemble chain.

    Returns:
        ``(n_samples, means)``: `S` sample counts (``step * W``) and `S x D` means.
    """
    chain = np.asarray(chain, dtype=np.float64)
    steps, walkers, _ = chain.shape
    per_step = chain.mean(axis=1)  # S x D
    cumulative = np.vstack([np.zeros((1, per_step.shape[1])), np.cumsum(per_step, axis=0)])
    ends = np.arange(1, steps + 1)
    starts = ends // 2
    means = (cumulative[ends] - cumulative[starts]) / (ends - starts)[:, None]
    return ends * walkers, means


def stabilisation_point(
    n: np.ndarray, estimates: np.ndarray, final: np.ndarray, sd: np.ndarray, tol: float = 0.1,
) -> float | None:
    """Smallest ``n[t]`` from which every later estimate is within ``tol * sd`` of ``final``.

    Args:
        n: `T` increasing counts (samples or evaluations).
        estimates: `T x D` estimates (e.g. means) at those counts.
        final: `D` final values.
        sd: `D` posterior standard deviations, the unit of the tolerance.
        tol: tolerance in standard deviations.

    Returns:
        The count, or None when even the last estimate is outside the tolerance.
    """
    inside = (np.abs(np.asarray(estimates) - np.asarray(final)) <= tol * np.asarray(sd)).all(axis=1)
    if inside.size == 0 or not inside[-1]:
        return None
    outside = np.flatnonzero(~inside)
    first = 0 if outside.size == 0 else int(outside[-1]) + 1
    return float(np.asarray(n)[first])


@dataclass(frozen=True)
class MarginalComparison:
    """One row of the Table 5 comparison (reference: MCMC)."""

    name: str
    mean_ref: float
    sd_ref: float
    mean: float
    sd: float

    @property
    def mean_shift(self) -> float:
        """``|mean - mean_ref| / sd_ref``."""
        return abs(self.mean - self.mean_ref) / self.sd_ref

    @property
    def sd_ratio(self) -> float:
        """``sd / sd_ref``."""
        return self.sd / self.sd_ref


def compare_marginals(names: Sequence[str], reference: np.ndarray, other: np.ndarray) -> list[MarginalComparison]:
    """Means and sds of two sample sets (`S x D`, `S' x D`) side by side, per parameter."""
    reference = np.asarray(reference, dtype=np.float64)
    other = np.asarray(other, dtype=np.float64)
    return [
        MarginalComparison(str(n), float(reference[:, i].mean()), float(reference[:, i].std(ddof=1)),
                           float(other[:, i].mean()), float(other[:, i].std(ddof=1)))
        for i, n in enumerate(names)
    ]


__all__ = [
    "MarginalComparison",
    "compare_marginals",
    "half_chain_means",
    "stabilisation_point",
    "window_stats",
]
