"""The adaptive field emulator as a registered method: its runner is
:func:`torchshm.inference.adaptive.method.run_emulator`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from torchshm.inference.registry import Method, Options, check_walkers, refuse, register_method

if TYPE_CHECKING:
    from torchshm.inference.posterior import Posterior
    from torchshm.problem import Problem


def check(options: Options, dim: int) -> None:
    """Refuse too few walkers, an unknown emulator kernel, a bad ``n_jobs`` or executor."""
    from torchshm.surrogate.gp import SURROGATE_KERNELS

    check_walkers("emulator", options.get("n_walkers"), dim)
    kernel = options.get("emulator_kernel")
    if kernel not in SURROGATE_KERNELS:
        refuse("emulator", f"emulator_kernel (method.emulator_kernel) must be one of {SURROGATE_KERNELS}, got {kernel!r}")
    n_jobs = options.get("n_jobs", 1)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
        refuse("emulator", f"n_jobs (method.n_jobs) must be a non-zero integer (-1: every core), got {n_jobs!r}")
    executor = options.get("executor")
    if executor is not None and not hasattr(executor, "submit"):
        refuse("emulator", f"executor must be a submitit executor "
                           f"(torchshm.make_executor(...)), got {type(executor).__name__}")


def _n_initial(options: Options, n_phys: int) -> int:
    """The initial design: ``n_initial``, else the runner's default
    (:func:`~torchshm.inference.adaptive.method.default_n_initial`)."""
    from torchshm.inference.adaptive.method import default_n_initial

    return int(options.get("n_initial") or default_n_initial(n_phys, int(options.get("batch_size", 5))))


def first_point(problem: Problem, seed: int, options: Options) -> np.ndarray:
    """The first point of the runner's initial Latin hypercube in the plausible box (the same
    design, so the output check's run is the design's first run, not an extra one)."""
    from torchshm.inference.adaptive.acquisition import design
    from torchshm.inference.adaptive.method import default_cap

    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    n_phys = len(problem.physical_names)
    batch = int(options.get("batch_size", 5))
    n_initial = _n_initial(options, n_phys)
    budget = options.get("max_model_evaluations")
    if budget is None:
        budget = default_cap(len(problem.names), n_initial, batch)
    budget = int(budget) - 1 if int(budget) > 1 else int(budget)  # as :func:`charge` leaves it
    return design(plausible, min(n_initial, max(budget, n_phys + 2)), seed)[0]


def runs_none(options: Options) -> bool:
    """``max_model_evaluations=0``: the emulator is fitted on stored runs only."""
    return options.get("max_model_evaluations") == 0


def charge(options: Options, dim: int, n_phys: int, checked: int) -> Options:
    """``max_model_evaluations`` (or the runner's default cap) less the checked run."""
    budget = options.get("max_model_evaluations")
    if budget is None:  # run_emulator's own default cap
        from torchshm.inference.adaptive.method import default_cap

        budget = default_cap(dim, _n_initial(options, n_phys), int(options.get("batch_size", 5)))
    budget = int(budget)
    return {**options, "max_model_evaluations": budget - checked} if budget > checked else options


def not_converged(post: Posterior) -> str:
    """The budget ran out before the stop rule held: raise ``max_model_evaluations``."""
    d = post.diagnostics
    rounds = d.get("rounds") or [{}]
    last = rounds[-1] if isinstance(rounds[-1], dict) else {}
    tv = last.get("tv")
    state = f"; last round TV {float(tv):.3f}" if isinstance(tv, (int, float)) else ""
    return (f"NOT CONVERGED: method='emulator' used its budget ({post.n_model_evaluations} "
            f"model runs, {d.get('n_rounds', len(rounds))} rounds{state}) before its stop "
            f"rule held; the posterior may still move: raise max_model_evaluations and "
            f"rerun on the same store (finished model runs are reused)")


EMULATOR = register_method(Method(
    "emulator", "torchshm.inference.adaptive.method:run_emulator", has_evidence=True,
    check=check, first_point=first_point, runs_none=runs_none, charge=charge,
    not_converged=not_converged,
))
