"""Is the noise model of Eq. (21) contradicted by the data? Whitened residuals near the posterior.

For a few posterior draws, the stored model run nearest to the draw's physical parameters
(``problem.evaluations()``: no new model run) gives the residuals ``y - eta`` of every block of
the problem; whitened by the Cholesky factor of the block's covariance
``sigma_m² diag(eta²) + K(sigma_a, l) + sigma_e² I`` at the draw, they are independent standard
normals if the noise model holds, so ``chi² / n`` is 1 within ``sqrt(2 / n)``. Far below 1 the
assumed noise (``sigma_m``, ``sigma_e``) is too large; far above, too small. Long blocks are
evaluated on at most :data:`MAX_POINTS` evenly spread positions (a Gaussian's marginal on a
subset is the same Gaussian restricted to it).

The warning threshold: ``chi² / n`` outside ``[1 / RATIO, RATIO]`` (a factor :data:`RATIO` in
variance, a practical difference), and more than :data:`Z_MAX` standard deviations
``sqrt(2 n)`` plus the number of fitted parameters (posterior draws, with ``sigma_a`` and
``l`` fitted to the same residuals, move ``chi²`` by about that many) from ``n``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.marginal import covariance

if TYPE_CHECKING:
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
        ``(line, {"noise_chi2_per_n", "noise_n", "noise_runs", "noise_run_distance",
        "noise_model_share"})``: the median ``chi² / n`` over the draws, the readings ``n``
        per draw, the draws used, the largest RMS distance [posterior sds] between a draw
        and its run, and the share of the assumed noise variance that is ``sigma_m² eta²``.
    """
    problem = post.problem
    if problem is None or not hasattr(problem, "evaluations"):
        return None, {}
    pairs = _draws_and_runs(post, problem)
    if not pairs:
        return None, {}
    values = [_chi2(problem, draw, out) for draw, out, _ in pairs]
    chi2 = float(np.median([v[0] for v in values]))
    n, share = values[0][1], float(np.median([v[2] for v in values]))
    numbers = {"noise_chi2_per_n": chi2 / n, "noise_n": float(n), "noise_runs": float(len(pairs)),
               "noise_run_distance": float(max(p[2] for p in pairs)), "noise_model_share": share}
    slack = Z_MAX * math.sqrt(2.0 * n) + len(post.names)
    ratio = chi2 / n
    if 1.0 / RATIO <= ratio <= RATIO or abs(chi2 - n) <= slack:
        return None, numbers
    return _line(problem, ratio, n, share, len(pairs)), numbers


def _draws_and_runs(post: Posterior, problem: Any) -> list[tuple[np.ndarray, np.ndarray, float]]:
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


def _chi2(problem: Any, draw: np.ndarray, outputs: np.ndarray) -> tuple[float, int, float]:
    """(chi², readings, share of sigma_m² eta² in the noise) of one draw's whitened residuals."""
    row = torch.as_tensor(draw, dtype=torch.float64)[None, :]
    eta = problem.at_measured(torch.as_tensor(outputs)[None])[0]  # L x n
    sigma_a, length = problem.split.discrepancy(row)
    sigma_m = _sigma_m(problem, row)
    y = torch.as_tensor(np.asarray(problem.measurements.y, dtype=np.float64))
    chi2, count, mult, total = 0.0, 0, 0.0, 0.0
    for block in problem.blocks:
        points = block.points
        keep = torch.as_tensor(np.unique(np.linspace(0, len(points) - 1, MAX_POINTS).round().astype(int))) \
            if len(points) > MAX_POINTS else torch.arange(len(points))
        idx, x = points[keep], block.x[keep]
        yb, eb = y[block.loads][:, idx], eta[block.loads][:, idx]  # L_b x n_b
        m2 = sigma_m**2 * eb.square()
        noise = (m2 + block.sigma_e**2)[None]  # 1 x L_b x n_b
        ell = torch.ones(1, dtype=torch.float64) if length is None else length[:, block.group]
        cov = covariance(x, problem.kernel, sigma_a[:, block.group], ell, noise)[0]
        chol, failed = cholesky_with_jitter(cov)
        if bool(failed.any()):
            continue
        z = torch.linalg.solve_triangular(chol, (yb - eb).unsqueeze(-1), upper=False)
        chi2 += float(z.square().sum())
        count += int(yb.numel())
        mult, total = mult + float(m2.sum()), total + float(noise.sum())
    return chi2, max(count, 1), mult / total if total > 0 else 0.0


def _sigma_m(problem: Any, row: torch.Tensor) -> float:
    """The multiplicative model error of the draw: its column when inferred, else the fixed one."""
    if "sigma_m" in getattr(problem, "names", ()):
        return float(row[0, list(problem.names).index("sigma_m")])
    return float(problem.sigma_m)


def _line(problem: Any, ratio: float, n: int, share: float, runs: int) -> str:
    """The ``NOISE MODEL`` warning for ``chi² / n = ratio``."""
    sigma_m, sigma_e = getattr(problem, "sigma_m", None), getattr(problem, "sigma_e", None)
    assumed = f"sigma_m = {sigma_m:g}" if isinstance(sigma_m, (int, float)) else "sigma_m"
    assumed += f", sigma_e = {sigma_e:g} µε" if isinstance(sigma_e, (int, float)) else ", sigma_e"
    head = (f"NOISE MODEL: whitened residuals of the measured strains at {runs} posterior "
            f"draws give chi²/n = {ratio:.3g} (n = {n}; 1 if the noise model held)")
    if ratio < 1.0:
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
