"""The end of the emulator method: the final chain, mixture density, evidence and
:class:`~torchshm.inference.Posterior` of :func:`~torchshm.inference.adaptive.method.run_emulator`."""

from __future__ import annotations

import logging
import time
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint
from torchshm.inference.adaptive.runs import RunSet
from torchshm.inference.posterior import Posterior
from torchshm.inference.tensorboard import RunTrace

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger("torchshm.inference.adaptive.method")


def finish(problem: Problem, log_joint: EmulatedLogJoint, walkers: np.ndarray,
               last: np.ndarray,
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
    vp = sampling.fit_density(chain, extra["hard"], extra["plausible"], seed)
    log_z, log_z_sd, ess, samples = sampling.importance(log_joint, vp, extra["n_evidence"], seed)
    if not converged:
        warnings.warn(
            f"method='emulator' stopped at its cap of {extra['budget']} model runs before "
            f"the stop rule held (last round: TV {rounds[-1]['tv']:.3f}, emulator "
            f"log-likelihood sd {rounds[-1]['emulator_loglik_sd']:.3f} nats, last batch off by "
            f"{rounds[-1]['check_loglik_error']:.3g} nats); the posterior may still move and "
            "is widened by the emulator's own uncertainty: raise max_model_evaluations",
            RuntimeWarning, stacklevel=3)
    diagnostics = {
        "rounds": rounds, "n_rounds": len(rounds), "n_failed_evaluations": runs.n_failed,
        "n_reused_runs": extra["n_reused_runs"], "n_emulator_runs": int(runs.theta_p.shape[0]),
        "evidence_ess": ess, "n_walkers": extra["n_walkers"],
        "wall_time_s": time.perf_counter() - extra["t0"],
        "final_cpu_time_s": time.process_time() - cpu,
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


__all__ = ["finish"]
