"""Identification with emcee's affine-invariant ensemble sampler (the paper's benchmark, Sec. 4).

Defaults follow the paper: 40 walkers, 2000 steps, walkers started from the prior. The log
joint of all walkers is computed in one batched call per step (``vectorize=True``). With
``backend_path`` the chain is written step by step to an ``emcee.backends.HDFBackend`` file, and
a run on an existing file continues from its last step for the steps that remain.
"""

from __future__ import annotations

import hashlib
import json
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import emcee
import numpy as np

from torchshm.forward.protocol import model_identity
from torchshm.inference.peer_errors import (
    NUMERICAL, PeerNumericalError, first_line, peer_of, where,
)
from torchshm.inference.posterior import Posterior
from torchshm.inference.target import LogJointTarget
from torchshm.inference.tensorboard import RunTrace, marginal_scalars

if TYPE_CHECKING:
    from torchshm.problem import Problem


#: a walker accepting less than this fraction of the median walker's acceptance is stuck
STUCK_RATIO = 0.25


def stuck_walkers(acceptance: np.ndarray) -> np.ndarray:
    """Indices of the walkers whose acceptance fraction is below ``STUCK_RATIO`` times the
    median walker's (e.g. 0.047 among walkers near 0.3): a walker caught in a low mode or at a
    bound, whose samples bias the posterior while the other walkers look healthy."""
    acceptance = np.asarray(acceptance, dtype=np.float64)
    median = float(np.median(acceptance)) if acceptance.size else 0.0
    return np.flatnonzero(acceptance < STUCK_RATIO * median)


def _problem_signature(problem: Problem) -> str:
    """What a resumed chain must share with the run that started it (JSON text)."""
    m = problem.measurements
    digest = hashlib.sha256()
    for values in (m.x, m.y, m.loads):
        digest.update(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return json.dumps({
        "names": list(problem.names),
        "kernel": getattr(problem.kernel, "name", str(problem.kernel)),
        "model": model_identity(problem.model), "measurements": digest.hexdigest()[:16],
    }, sort_keys=True)


def _check_resume(path: str | Path, signature: str, resuming: bool) -> None:
    """Refuse to continue a chain file written for another problem; record a new one's."""
    sidecar = Path(f"{path}.problem.json")
    if resuming and sidecar.is_file() and sidecar.read_text() != signature:
        raise ValueError(
            f"emcee: the chain in {path} was started for another problem "
            f"({sidecar.read_text()}); use another backend_path or delete it"
        )
    if not resuming:
        sidecar.write_text(signature)


def _backend(path: str | Path | None) -> emcee.backends.Backend:
    """An HDF backend at ``path`` (resumable), or an in-memory one."""
    if path is None:
        return emcee.backends.Backend()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return emcee.backends.HDFBackend(str(path), name="mcmc")


def _autocorr(backend: emcee.backends.Backend, discard: int, tol: float) -> np.ndarray:
    """Integrated autocorrelation time per parameter [steps] (NaN when it cannot be estimated)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.asarray(backend.get_autocorr_time(discard=discard, quiet=True, tol=tol))
    except Exception:  # too short a chain: emcee raises or returns NaN
        return np.full(backend.shape[1], np.nan)


def _checkpoint_row(
    backend: emcee.backends.Backend, names: list[str], window: int, n_calls: int,
) -> dict[str, float]:
    """Trace row after the steps done so far: marginals of the last ``window`` samples."""
    steps, n_walkers = int(backend.iteration), int(backend.shape[0])
    last = max(1, -(-window // n_walkers))
    chain = backend.get_chain(discard=max(0, steps - last))
    tau = _autocorr(backend, 0, tol=0)
    row = {
        "step": float(steps),
        "n_samples": float(steps * n_walkers),
        "n_model_evaluations": float(n_calls),
        "acceptance_fraction": float(np.mean(backend.accepted / max(1, steps))),
        "tau_max": float(np.nanmax(tau)) if np.isfinite(tau).any() else np.nan,
    }
    row.update(marginal_scalars(names, chain.reshape(-1, len(names))))
    return row


def run_emcee(
    problem: Problem,
    seed: int = 0,
    *,
    log_dir: str | Path | None = None,
    n_walkers: int = 40,
    n_steps: int = 2000,
    burn: int | None = None,
    thin: int = 1,
    backend_path: str | Path | None = None,
    log_every: int = 100,
    window: int = 1000,
    moves: Any = None,
    max_model_evaluations: int | None = None,
) -> Posterior:
    """Run emcee on ``problem`` (see :func:`torchshm.identify`).

    Args:
        problem: a :class:`~torchshm.Problem`.
        seed: seed of the initial walkers and of the sampler's generator.
        log_dir: TensorBoard folder, written every ``log_every`` steps, or None.
        n_walkers: walkers (paper: 40).
        n_steps: total steps per walker, those of a resumed run included (paper: 2000).
        burn: steps discarded at the start (None: the first half, ``n_steps // 2``).
        thin: keep every ``thin``-th step after burn-in.
        backend_path: HDF5 file of the chain; an existing one is continued.
        log_every: steps between trace rows.
        window: samples (steps x walkers) behind each trace row's running marginals (paper's
            Fig. 5: the last 1,000).
        moves: emcee moves (None: the stretch move, emcee's default).
        max_model_evaluations: a cap on model runs, the emulator's option of that name: the
            chain takes at most ``max_model_evaluations // n_walkers - 1`` steps in all (the
            walkers' starts take one run each; :func:`capped_steps`), fewer than ``n_steps``
            where the cap binds; or None.

    Returns:
        The :class:`Posterior`; ``converged`` is True when the chain after burn-in is at least
        50 integrated autocorrelation times long (emcee's reliability criterion).
    """
    t0 = time.perf_counter()
    names = list(problem.names)
    hard = np.asarray(problem.hard_bounds, dtype=np.float64)
    asked, n_steps = n_steps, capped_steps(n_steps, n_walkers, max_model_evaluations)
    burn = n_steps // 2 if burn is None else int(burn)
    if not 0 <= burn < n_steps:
        raise ValueError(f"emcee: burn must be in [0, n_steps), got burn={burn}, n_steps={n_steps}")
    if int(thin) < 1:
        raise ValueError(f"emcee: thin must be >= 1, got {thin}")
    if int(n_walkers) < 2 * len(problem.names):
        raise ValueError(
            f"emcee: n_walkers must be at least twice the number of parameters "
            f"({2 * len(problem.names)}), got {n_walkers}"
        )
    calls_before = int(problem.n_model_evaluations)
    target = LogJointTarget(problem, None, impute_failures=False, hard_bounds=hard)
    backend = _backend(backend_path)
    sampler = emcee.EnsembleSampler(
        n_walkers, len(names), target.evaluate, backend=backend, vectorize=True, moves=moves
    )
    done = int(backend.iteration) if backend_path is not None and backend.initialized else 0
    if backend_path is not None:
        _check_resume(backend_path, _problem_signature(problem), done > 0)
    if done > 0:
        state = backend.get_last_sample()
    else:
        p0 = problem.sample_prior(n_walkers, np.random.default_rng([seed, 3]))
        state = emcee.State(p0, random_state=np.random.RandomState(seed).get_state())
    trace = RunTrace(log_dir, step_key="n_samples")
    try:
        for _ in sampler.sample(state, iterations=max(0, n_steps - done), progress=False):
            steps = int(backend.iteration)
            if steps % max(1, log_every) == 0 or steps == n_steps:
                n_calls = int(problem.n_model_evaluations) - calls_before
                trace.log(_checkpoint_row(backend, names, window, n_calls))
    except NUMERICAL as err:
        usage = type(err) is ValueError and "condition" not in str(err)  # refused by emcee
        if peer_of(err) is None or usage:
            raise
        raise PeerNumericalError(
            f"emcee failed ({first_line(err)}, at {where(err)}) after {int(backend.iteration)} "
            f"steps: the walkers' positions are degenerate (they must be linearly independent: "
            f"no parameter may be the same for every walker) or their log joint is not finite; "
            f"start the walkers afresh (another seed, a new backend_path) or check the priors"
        ) from None
    finally:
        trace.close()
    return _posterior(problem, backend, trace, target, calls_before, burn, thin, {
        "n_walkers": n_walkers, "n_steps": int(backend.iteration), "n_resumed_steps": done,
        "burn": burn, "thin": thin, "wall_time_s": time.perf_counter() - t0,
        "capped_by_budget": n_steps < asked,
    })


def capped_steps(n_steps: int, n_walkers: int, max_model_evaluations: int | None) -> int:
    """Steps of a chain of ``n_walkers`` walkers: ``n_steps``, or fewer where a cap of
    ``max_model_evaluations`` model runs binds (at most one run per walker for its start and
    one per walker and step: a proposal outside the hard bounds runs none)."""
    if max_model_evaluations is None:
        return int(n_steps)
    return min(int(n_steps), int(max_model_evaluations) // int(n_walkers) - 1)


def _posterior(
    problem: Problem, backend: emcee.backends.Backend, trace: RunTrace, target: LogJointTarget,
    calls_before: int, burn: int, thin: int, extra: dict[str, Any],
) -> Posterior:
    """Assemble the :class:`Posterior` of a finished chain and warn when it is too short."""
    names = list(problem.names)
    n_walkers = int(backend.shape[0])
    tau = _autocorr(backend, burn, tol=0)
    kept = int(backend.iteration) - burn
    tau_max = float(np.nanmax(tau)) if np.isfinite(tau).any() else np.nan
    n_over_tau = kept / tau_max if np.isfinite(tau_max) else np.nan
    converged = bool(np.isfinite(n_over_tau) and n_over_tau >= 50.0)
    acceptance = backend.accepted / max(1, int(backend.iteration))
    diagnostics: dict[str, Any] = {
        **extra,
        "acceptance_fraction": float(np.mean(acceptance)),
        "acceptance_fraction_min": float(np.min(acceptance)),
        "stuck_walkers": stuck_walkers(acceptance).tolist(),
        "n_stuck_walkers": int(stuck_walkers(acceptance).size),
        "tau_max": tau_max,
        "n_over_tau": float(n_over_tau),
        "n_log_joint_evaluations": len(target.y),
        "n_failed_evaluations": int(target.n_failed),
        **{f"tau/{n}": float(t) for n, t in zip(names, tau)},
    }
    if not converged:
        warnings.warn(
            f"emcee: the chain after burn-in is {n_over_tau:.1f} autocorrelation times long "
            "(fewer than 50): the posterior and tau estimates may be unreliable; run more steps",
            RuntimeWarning, stacklevel=3,
        )
    stuck = diagnostics["stuck_walkers"]
    if stuck:
        shown = ", ".join(f"{i} ({acceptance[i]:.3f})" for i in stuck[:5])
        warnings.warn(
            f"emcee: {len(stuck)} of {n_walkers} walkers are stuck: walker(s) {shown}"
            f"{', ...' if len(stuck) > 5 else ''} accepted under {STUCK_RATIO:g} times the median "
            f"acceptance fraction {np.median(acceptance):.3f}; their samples bias the posterior: "
            "run more steps or start the walkers elsewhere",
            RuntimeWarning, stacklevel=3,
        )
    samples = backend.get_chain(discard=burn, thin=thin, flat=True)
    log_prob = backend.get_log_prob(discard=burn, thin=thin, flat=True)
    diagnostics["log_prob_max"] = float(np.max(log_prob))
    return Posterior(
        names=names, method="emcee", samples=np.asarray(samples, dtype=np.float64),
        n_model_evaluations=int(problem.n_model_evaluations) - calls_before,
        converged=converged, diagnostics=diagnostics,
        priors=dict(getattr(problem, "priors", {}) or {}), history=trace.history(),
        n_chains=n_walkers, problem=problem,
        sample_stats={"lp": np.asarray(log_prob, dtype=np.float64)},
    )
