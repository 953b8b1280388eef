"""A reference posterior of the four-parameter beam (``scripts/beam4.py``) on its own likelihood.

Two independent estimates, both with the model itself (no emulator):

1. **emcee from the mode.** The maximum a posteriori point is found by Nelder-Mead then
   L-BFGS-B from several prior draws and the truth (all must reach the same optimum, or the
   posterior may be multimodal and this is reported); the walkers start in a small ball around
   it, so that none is left in the prior's tails. The chain's autocorrelation times, acceptance
   fractions and per-walker log-density levels are reported; ``burn`` times the longest
   autocorrelation time is discarded.
2. **Importance sampling** from a multivariate Student-t (5 degrees of freedom) centred on the
   chain's mean with 1.5 times its covariance, with the effective sample size of the weights.

Usage: ``python scripts/beam4_reference.py`` (or ``bench_evaluations.py --part four_reference``).
"""

from __future__ import annotations

import time
from typing import Any, Callable

import emcee
import numpy as np
from scipy import optimize, stats
from scipy.special import logsumexp

from beam4 import TRUTH, beam4_log_joint, beam4_problem

LogDensity = Callable[[np.ndarray], np.ndarray]


def find_map(log_joint: LogDensity, hard: np.ndarray, starts: np.ndarray,
             ) -> tuple[np.ndarray, list[float]]:
    """The best optimum `D` from each start `S x D`, and every start's final log joint."""
    def loss(v: np.ndarray) -> float:
        value = float(log_joint(v)[0])
        return -value if np.isfinite(value) else 1e12

    best, found = None, []
    for s in starts:
        r = optimize.minimize(loss, s, method="Nelder-Mead", options={
            "maxiter": 20000, "maxfev": 20000, "xatol": 1e-8, "fatol": 1e-9, "adaptive": True})
        r = optimize.minimize(loss, r.x, method="L-BFGS-B", bounds=hard)
        found.append(-float(r.fun))
        if best is None or r.fun < best.fun:
            best = r
    assert best is not None
    return best.x, found


def emcee_from_mode(log_joint: LogDensity, mode: np.ndarray, n_walkers: int, n_steps: int,
                    seed: int, burn: float = 10.0) -> dict[str, Any]:
    """emcee from a ball of relative radius 1e-4 around ``mode``; chain diagnostics and moments.

    Returns:
        mean, sd (`D` lists), tau (autocorrelation times [steps]), n_over_tau (kept steps over
        the longest tau), acceptance (min, median, max over walkers), worst_walker_gap (how far
        [nats] the lowest walker's median log density lies below the median over walkers), the
        samples kept and the steps discarded.
    """
    rng = np.random.default_rng(seed)
    start = mode + 1e-4 * np.maximum(np.abs(mode), 1e-3) * rng.standard_normal((n_walkers,
                                                                               mode.size))
    sampler = emcee.EnsembleSampler(n_walkers, mode.size, log_joint, vectorize=True)
    state = emcee.State(start, random_state=np.random.RandomState(seed).get_state())
    sampler.run_mcmc(state, n_steps, progress=False)
    tau = sampler.get_autocorr_time(tol=0)
    discard = int(np.ceil(burn * tau.max()))
    chain = sampler.get_chain(discard=discard)  # steps x walkers x D
    flat = chain.reshape(-1, mode.size)
    levels = np.median(sampler.get_log_prob(discard=discard), axis=0)  # per walker
    acc = sampler.acceptance_fraction
    return {"mean": flat.mean(0).tolist(), "sd": flat.std(0, ddof=1).tolist(),
            "tau": tau.tolist(), "n_over_tau": float((n_steps - discard) / tau.max()),
            "discard": discard, "n_walkers": n_walkers, "steps": n_steps,
            "acceptance": [float(acc.min()), float(np.median(acc)), float(acc.max())],
            "worst_walker_gap": float(np.median(levels) - levels.min()),
            "walker_mean_spread": (chain.mean(0).std(0) / flat.std(0)).tolist(),
            "samples": flat}


def importance_check(log_joint: LogDensity, samples: np.ndarray, n: int, seed: int,
                     ) -> dict[str, Any]:
    """Self-normalised importance sampling from a Student-t widened around ``samples``."""
    proposal = stats.multivariate_t(samples.mean(0), 1.5**2 * np.cov(samples.T), df=5,
                                    seed=np.random.default_rng([seed, 3]))
    draws = proposal.rvs(n)
    log_w = np.concatenate([log_joint(c) for c in np.array_split(draws, max(1, n // 500))])
    log_w = np.where(np.isfinite(log_w), log_w - proposal.logpdf(draws), -np.inf)
    w = np.exp(log_w - log_w.max())
    w /= w.sum()
    mean = w @ draws
    sd = np.sqrt(w @ np.square(draws - mean) * n / (n - 1))
    return {"mean": mean.tolist(), "sd": sd.tolist(), "ess": float(1 / np.square(w).sum()),
            "n": n, "log_evidence": float(logsumexp(log_w) - np.log(n))}


def reference(n_walkers: int = 32, n_steps: int = 16000, n_starts: int = 6, n_importance: int = 40000,
              seed: int = 1) -> dict[str, Any]:
    """The MAP, the emcee reference from it and the importance-sampling check (JSON-ready)."""
    t0 = time.perf_counter()
    problem = beam4_problem()
    log_joint = beam4_log_joint(problem)
    check = problem.sample_prior(16, np.random.default_rng(seed))
    assert np.allclose(log_joint(check), np.asarray(problem.log_joint(check)))
    starts = np.vstack([problem.sample_prior(n_starts, np.random.default_rng([seed, 1])),
                        np.asarray(TRUTH)[None, :]])
    mode, found = find_map(log_joint, problem.hard_bounds, starts)
    chain = emcee_from_mode(log_joint, mode, n_walkers, n_steps, seed)
    samples = chain.pop("samples")
    return {"names": list(problem.names), "map": mode.tolist(), "map_log_joint_per_start": found,
            **chain, "importance": importance_check(log_joint, samples, n_importance, seed),
            "wall_s": time.perf_counter() - t0}


if __name__ == "__main__":
    import json

    print(json.dumps(reference(), indent=1))
