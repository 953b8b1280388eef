"""VBMC (PyVBMC) as a registered method: its runner is :func:`torchshm.inference.variational.run_vbmc`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from torchshm.inference.registry import Method, Options, refuse, register_method

if TYPE_CHECKING:
    from torchshm.inference.posterior import Posterior
    from torchshm.problem import Problem

#: PyVBMC's display levels
VBMC_DISPLAY = ("off", "iter", "full")


def pyvbmc_option_names() -> set[str] | None:
    """Every option name PyVBMC declares (its basic and advanced ``.ini`` files), or None
    when the installed PyVBMC does not say."""
    try:
        from pyvbmc.vbmc.options import declared_option_names
    except ImportError:
        return None
    return {str(n) for n in declared_option_names()}


def check(options: Options, dim: int) -> None:
    """Refuse a budget, display level or start VBMC would refuse after its start-up search."""
    from torchshm.inference.start import StartSettings, vbmc_budget

    vbmc_budget(dim, options)
    if options.get("display", "iter") not in VBMC_DISPLAY:
        refuse("vbmc", f"display (method.display) must be one of {VBMC_DISPLAY}, got {options['display']!r}")
    start = options.get("start")
    if start is not None and not isinstance(start, StartSettings):
        refuse("vbmc", f"start must be a torchshm.inference.start.StartSettings, got "
                       f"{type(start).__name__}")
    points = None if start is None else start.points
    if points is not None and np.atleast_2d(np.asarray(points)).shape[-1] != dim:
        refuse("vbmc", f"start.points must be `N x {dim}` (one column per inferred parameter), "
                       f"got shape {np.shape(points)}")


def first_point(problem: Problem, seed: int, options: Options) -> np.ndarray:
    """The first given start point, else the first point of the start-up Latin design, else
    the plausible box's centre."""
    from torchshm.inference.start import StartSettings, latin_design, vbmc_budget

    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    dim = plausible.shape[0]
    start = options.get("start") or StartSettings()
    if start.points is not None:
        return np.atleast_2d(np.asarray(start.points, dtype=np.float64))[0]
    settings = start.resolved(dim, vbmc_budget(dim, options))
    if settings.n_design:
        return latin_design(plausible, int(settings.n_design), seed)[0]
    return plausible.mean(axis=1)


def charge(options: Options, dim: int, n_phys: int, checked: int) -> Options:
    """``max_fun_evals`` less the checked run, when the budget keeps two start-up designs."""
    from torchshm.inference.start import vbmc_budget

    n_initial = int(options.get("fun_eval_start") or 10 * -(-(dim + 1) // 10))
    budget = vbmc_budget(dim, options) - checked
    return {**options, "max_fun_evals": budget} if budget >= 2 * n_initial else options


def not_converged(post: Posterior) -> str:
    """VBMC stopped before its stability test held: raise ``max_fun_evals``."""
    d = post.diagnostics
    evals = int(d.get("vbmc_func_count", post.n_model_evaluations)) + int(d.get("n_start_evaluations", 0))
    reason = str(d.get("message", "")).strip().rstrip(".") or "no convergence"
    return (f"NOT CONVERGED: VBMC stopped after {evals} evaluations before its stability "
            f"test held ({reason}); the posterior and ELBO may be off: raise max_fun_evals "
            f"(e.g. to {2 * int(evals)}) and rerun on the same store (finished model runs are reused)")


VBMC = register_method(Method(
    "vbmc", "torchshm.inference.variational:run_vbmc", has_evidence=True,
    pass_through=pyvbmc_option_names,
    pass_through_doc="PyVBMC's options (pyvbmc.vbmc.options.declared_option_names())", check=check, first_point=first_point, charge=charge,
    not_converged=not_converged, failed_runs="imputed the lowest log joint seen",
    aliases={"max_model_evaluations": "max_fun_evals"},
))
