"""Identification with Variational Bayesian Monte Carlo (PyVBMC), paper Section 2.2.

The steps of :func:`run_vbmc`: read back the points a previous run on the same store evaluated;
search briefly for the mode (:mod:`torchshm.inference.start`); run PyVBMC from there with the
problem's hard and plausible bounds, tracing every iteration; draw samples from the variational
posterior and flag a run that did not converge.
"""

from __future__ import annotations

import copy
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
from pyvbmc import VBMC

from torchshm.inference import blas
from torchshm.inference.peer_errors import (
    NUMERICAL, PeerNumericalError, first_line, log_joint_range, peer_of, where,
)
from torchshm.inference.posterior import Posterior
from torchshm.inference.start import StartSettings, find_start, vbmc_budget, vbmc_start
from torchshm.inference.target import LogJointTarget, point_log_for
from torchshm.inference.tensorboard import RunTrace, marginal_scalars
from torchshm.inference.vbmc_check import TOLERANCE, against_evaluations, misfit_line

if TYPE_CHECKING:
    from torchshm.problem import Problem
    from pyvbmc import VariationalPosterior

#: samples drawn from the variational posterior per iteration for the trace's intervals
TRACE_SAMPLES = 20_000
#: GP noise floor (``tol_gp_noise``, in log-joint units) of the restart after a numerical
#: failure inside PyVBMC (its default is sqrt(1e-5) = 0.003)
RESTART_GP_NOISE = 0.1


class IterationTrace:
    """Logs every finished VBMC iteration, read from PyVBMC's public ``iteration_history``.

    PyVBMC 1.5 has no per-iteration callback (its ``output_fcn`` option is never called), so the
    trace is read from ``vbmc.iteration_history``, where each iteration's ELBO, sKL, function
    count and variational posterior are recorded at its end. :meth:`poll` logs the iterations
    recorded since the last poll; it runs before every log-joint evaluation (:meth:`wrap`), so
    iteration `k` is written as soon as iteration `k + 1` asks for a point, and once more
    after the run (:meth:`poll` from :func:`run_vbmc`) for the last iteration. No PyVBMC
    method is overridden.

    Args:
        trace: where rows go (TensorBoard and the posterior's history).
        names: the inferred parameter names.
        n_precomputed: evaluations handed to PyVBMC before its first iteration.
        seed: seed of the run (the trace's draws use their own streams derived from it).
    """

    def __init__(self, trace: RunTrace, names: list[str], n_precomputed: int, seed: int) -> None:
        self.trace, self.names, self.n_precomputed, self.seed = trace, names, n_precomputed, seed
        self.vbmc: VBMC | None = None
        self.n_logged = 0

    def wrap(self, target: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
        """``target`` with a :meth:`poll` before each call."""

        def traced(theta: np.ndarray) -> np.ndarray:
            self.poll()
            with blas.model_work():
                return target(theta)

        return traced

    def poll(self) -> None:
        """Log the iterations recorded in ``iteration_history`` and not logged yet."""
        hist = None if self.vbmc is None else self.vbmc.iteration_history
        elbo = None if hist is None else hist["elbo"]
        while elbo is not None and self.n_logged < len(elbo) and elbo[self.n_logged] is not None:
            self.trace.log(_iteration_row(hist, self.n_logged, self.names, self.n_precomputed,
                                          self.seed))
            self.n_logged += 1


def _iteration_row(
    hist: Any, it: int, names: list[str], n_precomputed: int, seed: int
) -> dict[str, float]:
    """Trace row of iteration ``it`` of an ``iteration_history`` (ELBO, sKL, marginal intervals)."""
    vp = copy.deepcopy(hist["vp"][it])
    vp.rng = np.random.default_rng([seed, 7, it])  # never draw from the run's own stream
    draws, _ = vp.sample(TRACE_SAMPLES)
    row = {
        "iteration": float(it),
        "n_evaluations": float(hist["func_count"][it] + n_precomputed),
        "elbo": float(hist["elbo"][it]),
        "elbo_sd": float(hist["elbo_sd"][it]),
        "sKL": float(hist["sKL"][it]) if hist["sKL"][it] is not None else np.nan,
    }
    row.update(marginal_scalars(names, np.asarray(draws)))
    return row


def _pyvbmc_options(
    options: dict[str, Any], x0_rows: int, n_initial: int, dim: int
) -> dict[str, Any]:
    """PyVBMC options: the user's, with an initial design made of ``x0`` when it is short.

    With at least ``D + 1`` starting points (the best point and its probing star) the initial
    design is exactly those points (``fun_eval_start``); with fewer, the rest is drawn near the
    best point (``init_design="narrow"``) rather than in the whole plausible box.
    """
    opts = dict(options)
    if 0 < x0_rows < n_initial and "fun_eval_start" not in options:
        if x0_rows >= dim + 1:
            opts["fun_eval_start"] = x0_rows
        else:
            opts.setdefault("init_design", "narrow")
    return opts


def run_vbmc(
    problem: Problem,
    seed: int = 0,
    *,
    log_dir: str | Path | None = None,
    n_samples: int = 100_000,
    start: StartSettings | None = None,
    reuse: bool = True,
    **options: Any,
) -> Posterior:
    """Run PyVBMC on ``problem`` (see :func:`torchshm.identify`).

    Args:
        problem: a :class:`~torchshm.Problem` (or any object with its attributes).
        seed: seed of the starting design and of PyVBMC's generator.
        log_dir: TensorBoard folder for the live trace, or None.
        n_samples: samples drawn from the final variational posterior for ``post.samples``.
        start: settings of the mode search before VBMC (:class:`StartSettings`).
        reuse: start from the points a previous run on the same store evaluated.
        **options: PyVBMC options (e.g. ``max_fun_evals``, ``display``), passed through.

    Returns:
        The :class:`Posterior`; ``converged`` is PyVBMC's ``success_flag``.
    """
    t0 = time.perf_counter()
    names = list(problem.names)
    hard = np.asarray(problem.search_bounds, dtype=np.float64)
    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    budget = vbmc_budget(len(names), options)
    options = {k: v for k, v in options.items() if not (k == "max_fun_evals" and v is None)}
    calls_before = int(problem.n_model_evaluations)
    target = LogJointTarget(problem, point_log_for(problem), impute_failures=True, hard_bounds=hard)
    n_reused = _reuse_previous_points(target) if reuse else 0
    settings = (start or StartSettings()).resolved(len(names), budget)
    calls_before_search = int(problem.n_model_evaluations)
    first = find_start(target, plausible, hard, settings, seed)
    n_search = int(problem.n_model_evaluations) - calls_before_search  # charged to the budget
    n_initial = int(options.get("fun_eval_start", 10 * -(-(len(names) + 1) // 10)))
    x0, precomputed = vbmc_start(target, first, n_initial, float(settings.keep_threshold or 0))

    trace = RunTrace(log_dir, step_key="iteration")
    n_pre = 0 if precomputed is None else int(precomputed[0].shape[0])
    iterations = IterationTrace(trace, names, n_pre, seed)
    vbmc_options = _pyvbmc_options(options, 0 if x0 is None else x0.shape[0], n_initial, len(names))
    try:
        with blas.own_work():  # PyVBMC's NumPy work is small matrices: one BLAS thread
            vbmc = VBMC(
                iterations.wrap(target), x0, hard[:, 0], hard[:, 1], plausible[:, 0],
                plausible[:, 1], options=vbmc_options, seed=seed,
                precomputed_evaluations=precomputed, initialization_cost=n_search,
            )
            iterations.vbmc = vbmc
            vp, results, retried = _optimize(vbmc, iterations, target, first, settings, hard,
                                             plausible, vbmc_options, seed, n_search)
        iterations.poll()
    finally:
        trace.close()
    return _posterior(problem, vp, results, trace, target, calls_before, n_samples, seed, {
        "n_reused_points": n_reused, "n_precomputed": n_pre, "n_start_evaluations": n_search,
        "n_numerical_restarts": retried, "wall_time_s": time.perf_counter() - t0,
    })


def _optimize(
    vbmc: VBMC, iterations: IterationTrace, target: LogJointTarget, first: np.ndarray,
    settings: StartSettings, hard: np.ndarray, plausible: np.ndarray, options: dict[str, Any],
    seed: int, n_search: int,
) -> tuple[VariationalPosterior, dict[str, Any], int]:
    """``vbmc.optimize()``, restarted once after a numerical failure inside PyVBMC.

    The restart hands every point evaluated so far to a new PyVBMC run as precomputed
    evaluations (no model run is repeated), with another seed and a GP noise floor of
    :data:`RESTART_GP_NOISE` (``tol_gp_noise``), which keeps the GP's training covariance
    invertible when the log joint spans a huge range (nearly noiseless data). A second failure
    raises :class:`PeerNumericalError` naming the cause and what to change.

    Returns:
        ``(vp, results, restarts)``.
    """
    try:
        vp, results = vbmc.optimize()
        return vp, results, 0
    except NUMERICAL as err:
        if peer_of(err) is None:
            raise
        first_error = err
    iterations.poll()
    warnings.warn(f"VBMC: PyVBMC failed numerically ({first_line(first_error)}, at "
                  f"{where(first_error)}); restarting once from the {len(target.y)} points "
                  f"evaluated so far with tol_gp_noise={RESTART_GP_NOISE:g}",
                  RuntimeWarning, stacklevel=4)
    n_initial = int(options.get("fun_eval_start", 10 * -(-(hard.shape[0] + 1) // 10)))
    x0, precomputed = vbmc_start(target, first, n_initial, float(settings.keep_threshold or 0))
    restart_options = {**options, "tol_gp_noise": max(float(options.get("tol_gp_noise", 0.0)),
                                                      RESTART_GP_NOISE)}
    iterations.n_precomputed = 0 if precomputed is None else int(precomputed[0].shape[0])
    iterations.n_logged = 0
    try:
        vbmc = VBMC(iterations.wrap(target), x0, hard[:, 0], hard[:, 1], plausible[:, 0],
                    plausible[:, 1], options=restart_options, seed=seed + 1,
                    precomputed_evaluations=precomputed, initialization_cost=n_search)
        iterations.vbmc = vbmc
        vp, results = vbmc.optimize()
    except NUMERICAL as err:
        if peer_of(err) is None:
            raise
        raise PeerNumericalError(
            f"VBMC: PyVBMC's Gaussian process failed numerically twice ({first_line(first_error)} "
            f"at {where(first_error)}; then {first_line(err)} at {where(err)}), after "
            f"{log_joint_range(target.y)}: the log joint is too peaked for its GP, typically "
            "nearly noiseless data with sigma_m = 0. Change: give sigma_m > 0 (or a prior), use "
            "method='emulator' or 'emcee', or narrow the plausible bounds around the mode; "
            "finished model runs are in the store and are not repeated"
        ) from None
    return vp, results, 1


def _reuse_previous_points(target: LogJointTarget) -> int:
    """Evaluate (through the store: no model call) the points a previous run logged."""
    if target.point_log is None:
        return 0
    previous = target.point_log.read()
    if previous.shape[0]:
        target.evaluate(previous)
    return int(previous.shape[0])


def _posterior(
    problem: Problem, vp: VariationalPosterior, results: dict[str, Any], trace: RunTrace, target: LogJointTarget,
    calls_before: int, n_samples: int, seed: int, extra: dict[str, Any],
) -> Posterior:
    """Assemble the :class:`Posterior` of a finished PyVBMC run and warn when not converged
    (PyVBMC's stability test failed) or when the posterior underweights points of its bulk
    that VBMC evaluated (:mod:`torchshm.inference.vbmc_check`)."""
    converged = bool(results["success_flag"])
    diagnostics: dict[str, Any] = {
        "iterations": int(results["iterations"]),
        "vbmc_func_count": int(results["func_count"]),
        "n_log_joint_evaluations": len(target.y),
        "n_failed_evaluations": int(target.n_failed),
        "train_set_size": int(results["train_set_size"]),
        "components": int(results["components"]),
        "r_index": float(results["r_index"]),
        "convergence_status": str(results["convergence_status"]),
        "message": str(results["message"]),
        **extra,
    }
    n_calls = int(problem.n_model_evaluations) - calls_before
    draw_vp = copy.deepcopy(vp)
    draw_vp.rng = np.random.default_rng([seed, 11])
    samples, _ = draw_vp.sample(int(n_samples))
    vp.rng = np.random.default_rng([seed, 13])
    excess = against_evaluations(vp, *target.known(), samples, float(results["elbo"]))
    diagnostics.update(evaluated_excess=excess.largest, evaluated_bulk=excess.n_bulk,
                       evaluated_over=excess.n_over, evaluated_where=excess.where.tolist(),
                       misfit=bool(excess.largest > TOLERANCE))
    if diagnostics["misfit"]:  # the posterior against the log joint VBMC evaluated
        warnings.warn(misfit_line(diagnostics), RuntimeWarning, stacklevel=3)
    if not converged:
        warnings.warn(
            f"VBMC did not converge ({results['message'].strip()}); the posterior may be "
            f"inaccurate: increase max_fun_evals or check the bounds",
            RuntimeWarning, stacklevel=3,
        )
    if target.n_failed:
        warnings.warn(
            f"{target.n_failed} log-joint evaluations failed (model runs that did not finish); "
            f"they were given the lowest log joint seen; first error: "
            f"{target.error_text()}",
            RuntimeWarning, stacklevel=3,
        )
    return Posterior(
        names=list(problem.names), method="vbmc", samples=np.asarray(samples, dtype=np.float64),
        log_evidence=float(results["elbo"]), log_evidence_sd=float(results["elbo_sd"]),
        n_model_evaluations=n_calls, converged=converged, diagnostics=diagnostics,
        priors=dict(getattr(problem, "priors", {}) or {}), history=trace.history(),
        variational=vp, n_chains=1, problem=problem,
    )
