"""Reference posteriors on the model's own likelihood: MAP, emcee from the mode(s), evidence.

1. :func:`direct_log_joint`: ``Problem.log_joint`` computed straight from the model (no output
   cache, which would keep every θp of a long chain in memory); checked equal to it.
2. :func:`find_modes`: Nelder-Mead then L-BFGS-B from several starts; optima within
   ``keep`` nats of the best that are separated from it by a valley are distinct modes.
3. :func:`run_chain`: emcee (differential-evolution moves) from a small ball around a mode, in
   chunks, until the kept steps exceed ``n_tau`` integrated autocorrelation times.
4. :func:`importance`: importance sampling from a mixture of Student-t's (one per mode, centred
   on its chain, covariance widened), giving log Z, its sd (delta method), the ESS, the moments
   and the posterior weight of each mode.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import emcee
import numpy as np
import torch
from scipy import optimize, stats
from scipy.special import logsumexp

from torchshm.likelihood.blocks import blocks_log_likelihood

LogDensity = Callable[[np.ndarray], np.ndarray]


def direct_log_joint(problem: Any) -> LogDensity:
    """``problem.log_joint`` on rows `B x D` (numpy), without the problem's output cache."""
    model = problem.model
    y = torch.as_tensor(np.asarray(problem.measurements.y, dtype=np.float64))
    method = "state_space" if problem.kernel.name in ("exponential", "matern32", "matern52") \
        and problem.measurements.x.ndim == 1 else "dense"  # the O(n) form where it exists: equal, faster

    def log_joint(theta: np.ndarray) -> np.ndarray:
        rows = torch.as_tensor(np.atleast_2d(theta), dtype=torch.float64)
        out = problem.prior.log_prob(rows).clone()
        ok = torch.isfinite(out)
        if bool(ok.any()):
            theta_p = problem.split.physical(rows[ok])
            sigma_a, length = problem.split.discrepancy(rows[ok])
            eta = problem.at_measured(model(theta_p))
            out[ok] += blocks_log_likelihood(y, eta, problem.blocks, problem.kernel, sigma_a, length,
                                             problem.sigma_m, method=method)
        return torch.where(torch.isnan(out), -math.inf, out).numpy()  # -inf stays -inf

    return log_joint


def find_modes(log_joint: LogDensity, hard: np.ndarray, scale: np.ndarray, starts: np.ndarray,
               keep: float = 12.0) -> tuple[list[np.ndarray], list[float]]:
    """Distinct modes (best first) and every start's optimum log joint.

    ``scale`` `D`: widths (plausible box) used to compare positions and to optimise in.
    """
    lo = np.where(np.isfinite(hard[:, 0]), hard[:, 0], -np.inf)
    hi = np.where(np.isfinite(hard[:, 1]), hard[:, 1], np.inf)

    def loss(z: np.ndarray) -> float:
        v = float(log_joint(z * scale)[0])
        return -v if np.isfinite(v) else 1e12

    optima = []
    for s in starts:
        r = optimize.minimize(loss, s / scale, method="Nelder-Mead",
                              options={"maxfev": 3000, "xatol": 1e-7, "fatol": 1e-8, "adaptive": True})
        r = optimize.minimize(loss, r.x, method="L-BFGS-B",
                              bounds=list(zip(lo / scale, hi / scale)))
        optima.append((-float(r.fun), r.x * scale))
    optima.sort(key=lambda t: -t[0])
    modes: list[tuple[float, np.ndarray]] = []
    for value, x in optima:
        if value < optima[0][0] - keep:
            continue
        if all(_separated(log_joint, x, value, m, mv, scale) for mv, m in modes):
            modes.append((value, x))
    return [m for _, m in modes], [v for v, _ in optima]


def _separated(log_joint: LogDensity, a: np.ndarray, va: float, b: np.ndarray, vb: float,
               scale: np.ndarray) -> bool:
    """Whether ``a`` and ``b`` are apart (> 5 % of the box) with a valley of > 3 nats between."""
    if np.max(np.abs(a - b) / scale) < 0.05:
        return False
    path = log_joint(a + np.linspace(0.1, 0.9, 9)[:, None] * (b - a))
    return bool(np.min(path) < min(va, vb) - 3.0)


def run_chain(log_joint: LogDensity, mode: np.ndarray, scale: np.ndarray, hard: np.ndarray, seed: int,
              n_walkers: int = 24,
              n_tau: float = 50.0, chunk: int = 500, max_steps: int = 20000) -> dict[str, Any]:
    """emcee from a ball of radius 1e-3 of ``scale`` around ``mode`` until the kept steps (after
    a burn-in of ``max(300, 5 tau)``) exceed ``n_tau`` times the longest autocorrelation time.

    Returns:
        tau (`D`, steps), steps, burn, n_over_tau, acceptance (min, median, max), the kept
        samples `S x D` (thinned to about 2 per tau) and ``reached`` (n_over_tau >= n_tau).
    """
    rng = np.random.default_rng(seed)
    start = mode + 1e-3 * scale * rng.standard_normal((n_walkers, mode.size))
    start = np.clip(start, hard[:, 0] + 1e-4 * scale, hard[:, 1] - 1e-4 * scale)  # inside the support
    # no DESnookerMove: emcee 3.1.6 weighs its proposals by half the snooker's Jacobian
    # (dfm/emcee#531, fixed after that release), which narrows the chain: sds 8-10 % low on
    # beam2_user_gamma against a 25^4-point quadrature. The gamma = 1 jump carries walkers
    # between modes as the snooker did.
    moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.DEMove(gamma0=1.0), 0.2)]
    sampler = emcee.EnsembleSampler(n_walkers, mode.size, log_joint, vectorize=True, moves=moves)
    state = emcee.State(start, random_state=np.random.RandomState(seed).get_state())
    steps, tau, burn = 0, np.full(mode.size, np.inf), 0
    while steps < max_steps:
        state = sampler.run_mcmc(state, chunk, progress=False, skip_initial_state_check=True)
        steps += chunk
        burn = int(max(300, 5 * np.max(tau))) if np.isfinite(tau).all() else steps // 2
        tau = sampler.get_autocorr_time(discard=min(burn, steps // 2), tol=0)
        burn = int(min(max(300, 5 * tau.max()), steps // 2))
        if (steps - burn) / tau.max() >= n_tau:
            break
    thin = max(1, int(tau.max() / 2))
    samples = sampler.get_chain(discard=burn, thin=thin, flat=True)
    acc = sampler.acceptance_fraction
    return {"tau": tau.tolist(), "steps": steps, "burn": burn, "n_walkers": n_walkers,
            "n_over_tau": float((steps - burn) / tau.max()), "reached": bool((steps - burn) / tau.max() >= n_tau),
            "acceptance": [float(acc.min()), float(np.median(acc)), float(acc.max())],
            "samples": samples}


def importance(log_joint: LogDensity, chains: list[np.ndarray], n: int, seed: int, widen: float = 1.5,
               df: float = 4.0) -> dict[str, Any]:
    """Importance sampling from an equal mixture of Student-t's, one per chain (mode).

    Returns:
        log_evidence, log_evidence_sd (delta method), ess, n, mean, sd (`D`), mode_weights
        (posterior mass of each component's draws by responsibility), and ``weights``/``draws``.
    """
    rng = np.random.default_rng([seed, 7])
    comps = [stats.multivariate_t(c.mean(0), widen**2 * np.cov(c.T), df=df, seed=rng) for c in chains]
    k = len(comps)
    counts = rng.multinomial(n, np.full(k, 1.0 / k))
    draws = np.vstack([c.rvs(m).reshape(m, -1) for c, m in zip(comps, counts) if m > 0])
    logq_each = np.stack([c.logpdf(draws) for c in comps], 1) - np.log(k)  # n x k
    logq = logsumexp(logq_each, axis=1)
    logp = np.concatenate([log_joint(b) for b in np.array_split(draws, max(1, n // 400))])
    log_w = np.where(np.isfinite(logp), logp - logq, -np.inf)
    top = log_w.max()
    w = np.exp(log_w - top)
    log_z = float(top + np.log(w.mean()))
    sd = float(np.sqrt(w.var(ddof=1) / n) / w.mean())
    wn = w / w.sum()
    mean = wn @ draws
    resp = np.exp(logq_each - logq[:, None])
    return {"log_evidence": log_z, "log_evidence_sd": sd, "ess": float(1.0 / np.square(wn).sum()), "n": n,
            "mean": mean.tolist(), "sd": np.sqrt(wn @ np.square(draws - mean)).tolist(),
            "mode_weights": (wn @ resp).tolist(), "weights": wn, "draws": draws}
