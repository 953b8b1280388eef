"""The end of the emulator method: the final chain, mixture density, evidence and
:class:`~torchshm.inference.Posterior` of :func:`~torchshm.inference.adaptive.method.run_emulator`."""

from __future__ import annotations

import logging
import time
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.draws import posterior_draws
from torchshm.inference.adaptive.explore import N_SOBOL
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint
from torchshm.inference.adaptive.runs import RunSet
from torchshm.inference.adaptive.unsure import average_over_errors
from torchshm.inference.posterior import Posterior
from torchshm.inference.tensorboard import RunTrace

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger("torchshm.inference.adaptive.method")
#: a draw is beyond the runs when it lies this share of its parameter's range outside them
BEYOND_MARGIN = 0.05
#: the stop rule runs the model past the runs while this share of the posterior draws lies at
#: their edge or beyond it (:func:`edge_rows`); the check warns at this share beyond them
EXTRAPOLATION_SHARE = 0.05


def cap_reason(rounds: list[dict[str, Any]]) -> str:
    """Which part of the stop rule still failed at the cap, in words, from the rounds' rows.

    A posterior that had settled (TV, emulator sd and batch check held) while points of the box
    stayed unresolved is a different outcome from one still moving: the first is right about
    the mode it found and cannot rule out another; the second may be wrong about its own.
    """
    last = rounds[-1]
    if not last.get("settled"):
        return ("the posterior itself had not settled (the emulator was still learning where it "
                "lies)")
    first = len(rounds) - 1
    while first > 0 and rounds[first - 1].get("settled"):
        first -= 1
    parts = []
    if last.get("n_unresolved", 0) > 0:
        parts.append(f"{last['n_unresolved']:.0f} of {N_SOBOL} points of the box were still "
                     "unresolved, so a mode elsewhere in the box is not ruled out")
    if last.get("extrapolating"):
        parts.append("draws still lay at the edge of the runs")
    return (f"the posterior around the found mode had settled after "
            f"{rounds[first]['n_model_evaluations']:.0f} runs, but "
            + " and ".join(parts or ["its last round did not pass the rule"]))


def finish(problem: Problem, log_joint: EmulatedLogJoint, walkers: np.ndarray, last: np.ndarray,
           rounds: list[dict[str, Any]], runs: RunSet, trace: RunTrace, converged: bool,
           seed: int, extra: dict[str, Any]) -> Posterior:
    """Final chain (the last round's samples ``last`` `S x D` and ``n_final_steps`` more),
    mixture density and evidence on the last emulator; the Posterior."""
    cpu = time.process_time()
    chain = last  # the last round's chain is on this same emulator: continue it
    if extra["n_final_steps"] > 0:
        more, _ = sampling.run_chain(log_joint, walkers, extra["n_final_steps"], seed + 7,
                                     hop=extra["hop"])
        chain = np.concatenate([last, more])
    result, vp, source, passes = posterior_draws(log_joint, chain, extra["hard"],
                                                 extra["plausible"], extra["n_evidence"], seed)
    log_z, log_z_sd, samples = result.log_z, result.sd, result.draws
    spread = rounds[-1].get("evidence_sd", np.nan) if rounds else np.nan
    if np.isfinite(spread):  # the stop rule's evidence sd from the emulator's errors, in the sd
        log_z_sd = float(np.hypot(log_z_sd, spread))
    averaged = None
    if not converged:  # the emulator's uncertainty kept in the posterior (:mod:`.unsure`)
        averaged = average_over_errors(log_joint, np.asarray(samples), extra["hard"],
                                       extra["plausible"], extra["n_evidence"], seed,
                                       extra.get("error_draws"))
    if averaged is not None:
        samples, source = averaged.draws, "averaged over the emulator's errors"
        log_z_sd = float(np.hypot(log_z_sd, averaged.log_z_spread))
        vp = sampling.fit_density(samples, extra["hard"], extra["plausible"], seed)
    if not converged:
        kept = ("the posterior averages the posteriors of the emulator's possible errors "
                f"(their sd {averaged.error_sd:.3g} nats where it has weight; {averaged.ess:.0f} "
                "effective draws), so it is as wide as what the emulator does not know yet"
                if averaged is not None else "the posterior is the emulator mean's and may "
                "still move by what the emulator does not know yet")
        warnings.warn(
            f"method='emulator' stopped at its cap of {extra['budget']} model runs before "
            f"the stop rule held (last round: TV {rounds[-1]['tv']:.3f}, emulator "
            f"log-likelihood sd {rounds[-1]['emulator_loglik_sd']:.3f} nats, last batch off by "
            f"{rounds[-1]['check_loglik_error']:.3g} nats, {rounds[-1]['n_unresolved']:.0f} "
            f"unresolved points of the box, {rounds[-1]['beyond_runs']:.0%} of the draws beyond "
            f"the runs); {cap_reason(rounds)}; {kept}: raise max_model_evaluations",
            RuntimeWarning, stacklevel=3)
    diagnostics = {
        "rounds": rounds, "n_rounds": len(rounds), "n_failed_evaluations": runs.n_failed,
        "n_reused_runs": extra["n_reused_runs"], "n_emulator_runs": int(runs.theta_p.shape[0]),
        "evidence_ess": result.ess, "evidence_khat": result.khat, "posterior_draws": source,
        **passes,
        "averaged_over_errors": None if averaged is None else {
            "ess": averaged.ess, "log_evidence_spread": averaged.log_z_spread,
            "error_sd": averaged.error_sd, "n_points": averaged.n_points,
            "n_fields": averaged.n_fields},
        "n_walkers": extra["n_walkers"],
        "wall_time_s": time.perf_counter() - extra["t0"],
        "final_cpu_time_s": time.process_time() - cpu,
        **beyond_runs(np.asarray(samples), list(problem.names), list(problem.physical_names),
                      np.asarray(runs.theta_p, dtype=np.float64), extra["hard"]),
    }
    logger.info("emulator: %d runs from the store, %d new, %d rounds, %s", extra["n_reused_runs"],
                runs.n_new, len(rounds), "converged" if converged else "NOT converged")
    vp.rng = np.random.default_rng([seed, 13])
    return Posterior(
        names=list(problem.names), method="emulator", samples=samples, log_evidence=log_z,
        log_evidence_sd=log_z_sd, n_model_evaluations=runs.n_new, converged=converged,
        diagnostics=diagnostics, priors=dict(getattr(problem, "priors", {}) or {}),
        history=trace.history(), variational=vp, n_chains=1, problem=problem,
    )


def beyond_runs(samples: np.ndarray, names: list[str], physical: list[str], theta_p: np.ndarray,
                box: np.ndarray, margin: float = BEYOND_MARGIN) -> dict[str, dict[str, Any]]:
    """Share of the posterior draws beyond the range of the model runs, per physical parameter.

    Where the posterior reaches past every run the emulator extrapolates, and a rise it never
    saw stays hidden (``docs/inference.md``; the check's warning: :mod:`torchshm.inference.checks`).

    Args:
        samples: `S x D` posterior draws; names: their `D` names; physical: the `P` physical
            names, the columns of ``theta_p``, the `N x P` parameters of the runs.
        box: `D x 2` search bounds; a draw counts when it lies more than ``margin`` of its
            parameter's range outside the runs' range.

    Returns:
        ``{"beyond_runs": {name: share}, "runs_range": {name: [low, high]}}``.
    """
    shares: dict[str, float] = {}
    ranges: dict[str, list[float]] = {}
    if theta_p.shape[0] == 0:
        return {"beyond_runs": shares, "runs_range": ranges}
    for j, name in enumerate(physical):
        k = names.index(name)
        shares[name] = float(beyond_rows(samples, [k], theta_p[:, [j]], box, margin).mean())
        ranges[name] = [float(theta_p[:, j].min()), float(theta_p[:, j].max())]
    return {"beyond_runs": shares, "runs_range": ranges}


def _past(samples: np.ndarray, columns: list[int], theta_p: np.ndarray, box: np.ndarray,
          shift: float, short_only: bool) -> np.ndarray:
    """`S` whether each draw lies past the runs' last value moved outwards by ``shift`` of its
    parameter's search range (inwards when negative), in some physical parameter; with
    ``short_only`` only on the sides where the runs stop short of the search ``box`` by more
    than ``|shift|`` of the range."""
    out = np.zeros(samples.shape[0], dtype=bool)
    for j, k in enumerate(columns):
        pad = abs(shift) * float(box[k, 1] - box[k, 0])
        x, low, high = samples[:, k], theta_p[:, j].min(), theta_p[:, j].max()
        step = np.sign(shift) * pad
        if not short_only or high < box[k, 1] - pad:
            out |= x > high + step
        if not short_only or low > box[k, 0] + pad:
            out |= x < low - step
    return out


def beyond_rows(samples: np.ndarray, columns: list[int], theta_p: np.ndarray, box: np.ndarray,
                margin: float = BEYOND_MARGIN) -> np.ndarray:
    """`S` whether each draw lies beyond the runs' range in some physical parameter.

    Args:
        samples: `S x D` draws; columns: where the `P` physical parameters (the columns of
            ``theta_p``, `N x P` runs) sit in a draw; box: `D x 2` search bounds; a draw is
            beyond when it lies more than ``margin`` of its parameter's range outside the runs.
    """
    return _past(samples, columns, theta_p, box, margin, short_only=False)


def edge_rows(samples: np.ndarray, columns: list[int], theta_p: np.ndarray, box: np.ndarray,
              margin: float = BEYOND_MARGIN) -> np.ndarray:
    """`S` whether each draw lies at the edge of the runs' range or past it, on a side where
    the runs stop short of the search ``box`` `D x 2`: within ``margin`` of the parameter's
    range inside the runs' last value, or beyond it (arguments as :func:`beyond_rows`).

    Past the last run the emulator extends what it saw, and a plateau that goes on (a spring
    stiff enough to act as a clamp, up to its prior bound) is cut where the runs end: the
    emulated log joint falls there, so few draws lie *beyond* the runs while many pile up at
    their edge. On the suite's ``beam2_saturating`` the runs reached ``log10_k_A`` 12.3 of the
    bound 13, 12 % of the draws lay within 0.4 of that edge, and the emulator's sd of it was
    0.78 of the reference's (``docs/inference.md`` step 7).
    """
    return _past(samples, columns, theta_p, box, -margin, short_only=True)


def extrapolation_run(samples: np.ndarray, edge: np.ndarray, columns: list[int],
                      theta_p: np.ndarray, box: np.ndarray, margin: float = BEYOND_MARGIN) -> np.ndarray:
    """`1 x D` one run past the runs' range: the draw of ``samples`` `S x D` (``edge`` `S` marks
    those at the edge of the runs or past it, :func:`edge_rows`) that lies farthest out, in
    shares of the search ``box``, moved to at least ``margin`` of the range past the runs'
    last value in that parameter (within the box). One run there extends the range over every
    draw out in that direction."""
    rows = samples[edge]
    width = box[columns, 1] - box[columns, 0]
    low, high = theta_p.min(0), theta_p.max(0)
    past = np.maximum(low - rows[:, columns], rows[:, columns] - high) / width
    i = int(np.argmax(past.max(1)))
    j = int(np.argmax(past[i]))
    run = rows[[i]].copy()
    k, pad = columns[j], margin * float(width[j])
    if rows[i, k] - high[j] >= low[j] - rows[i, k]:  # out on the high side
        run[0, k] = min(max(rows[i, k], high[j] + pad), box[k, 1])
    else:
        run[0, k] = max(min(rows[i, k], low[j] - pad), box[k, 0])
    return run


__all__ = ["BEYOND_MARGIN", "EXTRAPOLATION_SHARE", "beyond_rows", "beyond_runs", "edge_rows",
           "extrapolation_run", "finish"]
