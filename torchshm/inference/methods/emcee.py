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
    """Refuse too few walkers and a burn-in outside ``[0, n_steps)``."""
    check_walkers("emcee", options.get("n_walkers"), dim)
    burn, n_steps = options.get("burn"), options.get("n_steps")
    if burn is not None and not 0 <= burn < n_steps:
        refuse("emcee", f"burn (method.burn) must be in [0, n_steps) = [0, {n_steps}), got {burn}; lower burn "
                        "or raise n_steps")


def first_point(problem: Problem, seed: int, options: Options) -> np.ndarray:
    """The first walker's start: the first of ``n_walkers`` prior draws."""
    n_walkers = int(options.get("n_walkers", 40))
    return problem.sample_prior(n_walkers, np.random.default_rng([seed, 3]))[0]


def not_converged(post: Posterior) -> str:
    """The chain is shorter than 50 autocorrelation times: raise ``n_steps``."""
    d = post.diagnostics
    n_over_tau, steps = float(d.get("n_over_tau", math.nan)), int(d.get("n_steps", 0))
    if not math.isfinite(n_over_tau):
        return (f"NOT CONVERGED: emcee's autocorrelation time could not be estimated from "
                f"{steps} steps (too short a chain): raise n_steps (e.g. to {4 * steps}); "
                "with backend_path the chain continues")
    need = int(math.ceil(steps * 50.0 / max(n_over_tau, 1e-3) / 100.0) * 100)
    return (f"NOT CONVERGED: emcee's chain after burn-in is {n_over_tau:.1f} "
            f"autocorrelation times long (50 needed); the posterior may be off: raise "
            f"n_steps (about {need}); with backend_path the chain continues")


EMCEE = register_method(Method(
    "emcee", "torchshm.inference.mcmc:run_emcee", check=check, first_point=first_point,
    not_converged=not_converged,
))
