"""Is the noise model of Eq. (21) contradicted by the data? Whitened residuals near the posterior.

For a few posterior draws, the stored model run nearest to the draw's physical parameters
(``problem.evaluations()``: no new model run) gives the residuals ``y - eta`` of every block of
the problem; whitened by the Cholesky factor of the block's covariance
``sigma_m² diag(eta²) + K(sigma_a, l) + sigma_e² I`` at the draw, they are independent standard
normals if the noise model holds, so ``chi² / n`` is 1 within ``sqrt(2 / n)``. Far below 1 the
assumed noise (``sigma_m``, ``sigma_e``) is too large; far above, too small. Long blocks are
evaluated on at most :data:`MAX_POINTS` evenly spread positions (a Gaussian's marginal on a
subset is the same Gaussian restricted to it).

A posterior in the wrong place can look consistent by ``chi²`` alone: a modulus pushed to its
bound leaves a large smooth misfit, which a large ``sigma_a`` absorbs, and ``chi² / n`` comes
out near 1. The point-to-point scatter tells the white part of the noise model apart from the
smooth one: along each 1-D line the differences of neighbouring residuals remove the smooth
misfit, and their mean square is compared with what the covariance predicts for them
(``Σ_ii + Σ_jj - 2 Σ_ij``): the *scatter ratio*, 1 if the noise model holds.

The warning threshold, for either ratio: outside ``[1 / RATIO, RATIO]`` (a factor :data:`RATIO`
in variance, a practical difference), and more than :data:`Z_MAX` standard deviations from 1
(``chi²``: ``sqrt(2 n)`` plus the number of fitted parameters, since posterior draws, with
``sigma_a`` and ``l`` fitted to the same residuals, move ``chi²`` by about that many; the
scatter ratio: ``2 / sqrt(m)`` for `m` differences, neighbours being correlated).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.marginal import covariance

if TYPE_CHECKING:
    from torchshm.problem import Problem
    from torchshm.inference.posterior import Posterior

#: posterior draws at which the residuals are whitened
N_DRAWS = 10
#: most positions of one block used (evenly spread)
MAX_POINTS = 800
#: a draw uses the nearest stored run within this RMS distance in posterior sds
MAX_DISTANCE = 3.0
#: chi²/n must lie outside [1/RATIO, RATIO] for a warning
RATIO = 2.0
#: ... and further than Z_MAX sqrt(2 n) + D from n
Z_MAX = 5.0


def noise_check(post: Posterior) -> tuple[str | None, dict[str, float]]:
    """The ``NOISE MODEL`` warning line (or None) and the numbers behind it.

    Skipped (``(None, {})``) without a problem attached (a posterior loaded from a file), or
    when no stored run lies near the posterior.

    Returns:
        ``(line, {"noise_chi2_per_n", "noise_n", "noise_scatter_ratio",
        "noise_n_differences", "noise_runs", "noise_run_distance", "noise_model_share"})``:
        medians over the draws of ``chi² / n``, of the readings ``n``, of the scatter ratio
        (NaN without 1-D lines) and of its differences ``m``; the draws used, the largest RMS
        distance [posterior sds] between a draw and its run, and the share of the assumed
        white noise variance that is ``sigma_m² eta²``.
    """
    problem = post.problem
    if problem is None or not hasattr(problem, "evaluations"):
        return None, {}
    pairs = _draws_and_runs(post, problem)
    if not pairs:
        return None, {}
    stats = np.array([_statistics(problem, draw, out) for draw, out, _ in pairs])
    chi2, n, diff, pred, m, share = (float(v) for v in np.median(stats, axis=0))
    scatter = diff / pred if pred > 0 else math.nan
    numbers = {"noise_chi2_per_n": chi2 / n, "noise_n": n, "noise_scatter_ratio": scatter,
               "noise_n_differences": m, "noise_runs": float(len(pairs)),
               "noise_run_distance": float(max(p[2] for p in pairs)), "noise_model_share": share}
    off_chi2 = _off(chi2 / n, (Z_MAX * math.sqrt(2.0 * n) + len(post.names)) / n)
    off_scatter = _off(scatter, Z_MAX * 2.0 / math.sqrt(m)) if m > 0 else 0
    direction = off_scatter or off_chi2
    if not direction:
        return None, numbers
    return _line(problem, direction, chi2 / n, scatter, int(n), share, len(pairs)), numbers


def _off(ratio: float, tolerance: float) -> int:
    """-1 (too low), +1 (too high) or 0 for a ratio expected to be 1 within ``tolerance``."""
    if not math.isfinite(ratio) or (1.0 / RATIO <= ratio <= RATIO) or abs(ratio - 1.0) <= tolerance:
        return 0
    return -1 if ratio < 1.0 else 1


def _draws_and_runs(post: Posterior, problem: Problem) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Up to :data:`N_DRAWS` (draw `D`, outputs `L_model x n_model`, distance) triples."""
    try:
        theta_runs, outputs = problem.evaluations()
    except Exception:  # noqa: BLE001 - a damaged store must not fail a finished fit
        return []
    if len(theta_runs) == 0:
        return []
    rng = np.random.default_rng(0)
    samples = np.asarray(post.samples, dtype=np.float64)
    draws = samples[rng.choice(samples.shape[0], size=min(N_DRAWS, samples.shape[0]), replace=False)]
    split = problem.split
    spread = split.physical(samples[:: max(1, samples.shape[0] // 4000)]).numpy().std(axis=0)
    scale = np.where(spread > 0, spread, 1.0)
    runs = np.asarray(theta_runs, dtype=np.float64) / scale
    free = max(1, int(np.sum(spread > 0)))
    out = []
    for draw in draws:
        target = split.physical(draw[None, :]).numpy()[0] / scale
        dist = np.sqrt(np.sum((runs - target) ** 2, axis=1) / free)
        best = int(np.argmin(dist))
        if dist[best] <= MAX_DISTANCE:
            out.append((draw, np.asarray(outputs[best], dtype=np.float64), float(dist[best])))
    return out


def _statistics(problem: Problem, draw: np.ndarray, outputs: np.ndarray) -> tuple[float, ...]:
    """``(chi², n, sum of squared neighbour differences, their predicted sum, m, share of
    sigma_m² eta² in the white noise)`` of one draw's residuals over every block."""
    row = torch.as_tensor(draw, dtype=torch.float64)[None, :]
    eta = problem.at_measured(torch.as_tensor(outputs)[None])[0]  # L x n
    sigma_a, length = problem.split.discrepancy(row)
    sigma_m, e_scale = _noise_levels(problem, row)
    y = torch.as_tensor(np.asarray(problem.measurements.y, dtype=np.float64))
    chi2 = count = diff = pred = m = mult = total = 0.0
    for block in problem.blocks:
        points = block.points
        keep = torch.as_tensor(np.unique(np.linspace(0, len(points) - 1, MAX_POINTS).round().astype(int))) \
            if len(points) > MAX_POINTS else torch.arange(len(points))
        idx, x = points[keep], block.x[keep]
        yb, eb = y[block.loads][:, idx], eta[block.loads][:, idx]  # L_b x n_b
        m2 = sigma_m**2 * eb.square()
        noise = (m2 + (block.sigma_e * e_scale) ** 2)[None]  # 1 x L_b x n_b
        ell = torch.ones(1, dtype=torch.float64) if length is None else length[:, block.group]
        cov = covariance(x, problem.kernel, sigma_a[:, block.group], ell, noise)[0]  # L_b x n_b x n_b
        chol, failed = cholesky_with_jitter(cov)
        if bool(failed.any()):
            continue
        resid = yb - eb
        z = torch.linalg.solve_triangular(chol, resid.unsqueeze(-1), upper=False)
        chi2, count = chi2 + float(z.square().sum()), count + int(yb.numel())
        mult, total = mult + float(m2.sum()), total + float(noise.sum())
        if x.ndim == 1 and x.shape[0] > 1:  # neighbours along a line
            var = cov.diagonal(dim1=-2, dim2=-1)
            near = cov.diagonal(offset=1, dim1=-2, dim2=-1)
            diff += float(resid.diff(dim=-1).square().sum())
            pred += float((var[:, 1:] + var[:, :-1] - 2.0 * near).sum())
            m += resid.shape[0] * (resid.shape[1] - 1)
    return chi2, max(count, 1), diff, pred, m, mult / total if total > 0 else 0.0


def _noise_levels(problem: Problem, row: torch.Tensor) -> tuple[float, float]:
    """``(sigma_m, factor on every block's sigma_e)`` of one draw: inferred or fixed."""
    if hasattr(problem, "noise_of"):
        sigma_m, _, _, scale = problem.noise_of(row)
        return float(np.asarray(sigma_m).reshape(-1)[0]), 1.0 if scale is None else float(scale[0])
    return float(problem.sigma_m), 1.0


def _line(problem: Problem, direction: int, chi2: float, scatter: float, n: int, share: float,
          runs: int) -> str:
    """The ``NOISE MODEL`` warning: the noise model too large (``direction < 0``) or too small."""
    sigma_m, sigma_e = getattr(problem, "sigma_m", None), getattr(problem, "sigma_e", None)
    assumed = f"sigma_m = {sigma_m:g}" if isinstance(sigma_m, (int, float)) else "sigma_m (inferred)"
    assumed += (f", sigma_e = {sigma_e:g} µε" if isinstance(sigma_e, (int, float)) else
                ", sigma_e per line" if isinstance(sigma_e, dict) else ", sigma_e (inferred)")
    scatter_text = "" if not math.isfinite(scatter) else f", neighbour scatter ratio {scatter:.3g}"
    head = (f"NOISE MODEL: residuals of the measured strains at {runs} posterior draws give "
            f"chi²/n = {chi2:.3g}{scatter_text} (n = {n}; both 1 if the noise model held)")
    if direction < 0:
        ratio = scatter if math.isfinite(scatter) and scatter < 1.0 else chi2
        culprit = "sigma_m" if share >= 0.5 else "sigma_e"
        smaller = (f"a smaller sigma_m (about {float(sigma_m) * math.sqrt(ratio):.2g})"
                   if culprit == "sigma_m" and isinstance(sigma_m, (int, float)) else
                   "a smaller sigma_e (the sensor's noise)")
        return (f"{head}: the assumed noise ({assumed}) is too large, the data are less noisy "
                f"than the noise model says ({culprit} dominates it); the multiplicative term "
                "sigma_m² diag(η²) then favours small predictions (stiffer structures) and can "
                "push a modulus to its prior bound. Fix: give sigma_m a prior "
                f"(Problem(sigma_m=ts.Gamma(...))) or {smaller}")
    return (f"{head}: the assumed noise ({assumed}) is too small, the data are noisier than "
            "the noise model says, so the posterior is too narrow. Fix: check sigma_e against "
            "the sensor's noise, give sigma_m a prior (Problem(sigma_m=ts.Gamma(...))) or a "
            "larger value, or try another discrepancy kernel")


__all__ = ["MAX_POINTS", "N_DRAWS", "RATIO", "Z_MAX", "noise_check"]
