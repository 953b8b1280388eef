"""emcee's ensemble sampler as a registered method: its runner is
:func:`torchshm.inference.mcmc.run_emcee`."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from torchshm.inference.registry import Method, Options, check_walkers, refuse, register_method

if TYPE_CHECKING:
    from torchshm.inference.posterior import Posterior
    from torchshm.problem import Problem


def check(options: Options, dim: int) -> None:
    """Refuse too few walkers, a budget of fewer than two steps and a burn-in outside
    ``[0, n_steps)`` (the steps the budget leaves)."""
    from torchshm.inference.mcmc import capped_steps

    check_walkers("emcee", options.get("n_walkers"), dim)
    burn, n_walkers, cap = options.get("burn"), options.get("n_walkers", 40), options.get("max_model_evaluations")
    n_steps = capped_steps(options.get("n_steps", 2000), n_walkers, cap)
    if cap is not None and n_steps < 2:
        refuse("emcee", f"max_model_evaluations (method.max_model_evaluations) = {cap} leaves {n_steps} "
                        f"step(s) of {n_walkers} walkers (one model run per walker for its start and per walker "
                        f"and step); raise it to at least {3 * n_walkers}, or lower n_walkers")
    if burn is not None and not 0 <= burn < n_steps:
        what = "n_steps" if cap is None or n_steps == options.get("n_steps") else "the steps max_model_evaluations leaves"
        refuse("emcee", f"burn (method.burn) must be in [0, n_steps) = [0, {n_steps}), got {burn}; lower burn "
                        f"or raise {what}")


def first_point(problem: Problem, seed: int, options: Options) -> np.ndarray:
    """The first walker's start: the first of ``n_walkers`` prior draws."""
    n_walkers = int(options.get("n_walkers", 40))
    return problem.sample_prior(n_walkers, np.random.default_rng([seed, 3]))[0]


def not_converged(post: Posterior) -> str:
    """The chain is shorter than 50 autocorrelation times: raise ``n_steps``."""
    d = post.diagnostics
    n_over_tau, steps = float(d.get("n_over_tau", math.nan)), int(d.get("n_steps", 0))
    walkers, capped = int(d.get("n_walkers", 40)), bool(d.get("capped_by_budget"))
    if not math.isfinite(n_over_tau):
        what = f"n_steps (e.g. to {4 * steps})"
        if capped:  # the budget, not n_steps, ended the chain
            what = f"max_model_evaluations (e.g. to {(4 * steps + 1) * walkers})"
        return (f"NOT CONVERGED: emcee's autocorrelation time could not be estimated from "
                f"{steps} steps (too short a chain): raise {what}; "
                "with backend_path the chain continues")
    need = int(math.ceil(steps * 50.0 / max(n_over_tau, 1e-3) / 100.0) * 100)
    what = f"n_steps (about {need})"
    if capped:
        what = f"max_model_evaluations (about {(need + 1) * walkers})"
    return (f"NOT CONVERGED: emcee's chain after burn-in is {n_over_tau:.1f} "
            f"autocorrelation times long (50 needed); the posterior may be off: raise "
            f"{what}; with backend_path the chain continues")


def charge(options: Options, dim: int, n_phys: int, checked: int) -> Options:
    """``max_model_evaluations`` less the checked run, where one is set."""
    cap = options.get("max_model_evaluations")
    return options if cap is None else {**options, "max_model_evaluations": max(0, int(cap) - checked)}


EMCEE = register_method(Method(
    "emcee", "torchshm.inference.mcmc:run_emcee", check=check, first_point=first_point,
    not_converged=not_converged, charge=charge,
))
