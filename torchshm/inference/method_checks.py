"""The checks of :mod:`torchshm.inference.validate` that belong to one method.

:func:`check_method_options` refuses, before any model run, the option values a method would
refuse only later (after its start-up search, or after its budget); :func:`first_point` is the
first parameter vector the method evaluates, where the one model run of the output check is
made so that the method finds it in the cache or store instead of running it again.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: PyVBMC's display levels
VBMC_DISPLAY = ("off", "iter", "full")


def check_method_options(method: str, options: dict[str, Any], dim: int) -> None:
    """Refuse what ``method`` would refuse later. ``options`` holds every option: the user's
    over the runner's defaults; ``dim`` is `D`, the number of inferred parameters."""
    check = {"vbmc": _vbmc, "emcee": _emcee, "emulator": _emulator}.get(method)
    if check is not None:
        check(options, dim)


def _refuse(method: str, text: str) -> None:
    raise ValueError(f"identify: method={method!r}: {text}")


def _walkers(method: str, n_walkers: Any, dim: int) -> None:
    if n_walkers is not None and n_walkers < 2 * dim:
        _refuse(method, f"n_walkers (method.n_walkers) must be at least twice the number of parameters "
                        f"(2 x {dim} = {2 * dim}), got {n_walkers}; raise n_walkers")


def _vbmc(options: dict[str, Any], dim: int) -> None:
    from torchshm.inference.start import StartSettings, vbmc_budget

    vbmc_budget(dim, options)
    if options.get("display", "iter") not in VBMC_DISPLAY:
        _refuse("vbmc", f"display (method.display) must be one of {VBMC_DISPLAY}, got {options['display']!r}")
    start = options.get("start")
    if start is not None and not isinstance(start, StartSettings):
        _refuse("vbmc", f"start must be a torchshm.inference.start.StartSettings, got "
                        f"{type(start).__name__}")
    points = None if start is None else start.points
    if points is not None and np.atleast_2d(np.asarray(points)).shape[-1] != dim:
        _refuse("vbmc", f"start.points must be `N x {dim}` (one column per inferred parameter), "
                        f"got shape {np.shape(points)}")


def _emcee(options: dict[str, Any], dim: int) -> None:
    _walkers("emcee", options.get("n_walkers"), dim)
    burn, n_steps = options.get("burn"), options.get("n_steps")
    if burn is not None and not 0 <= burn < n_steps:
        _refuse("emcee", f"burn (method.burn) must be in [0, n_steps) = [0, {n_steps}), got {burn}; lower burn "
                         "or raise n_steps")


def _emulator(options: dict[str, Any], dim: int) -> None:
    from torchshm.surrogate.gp import SURROGATE_KERNELS

    _walkers("emulator", options.get("n_walkers"), dim)
    kernel = options.get("emulator_kernel")
    if kernel not in SURROGATE_KERNELS:
        _refuse("emulator", f"emulator_kernel (method.emulator_kernel) must be one of {SURROGATE_KERNELS}, got {kernel!r}")
    n_jobs = options.get("n_jobs", 1)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
        _refuse("emulator", f"n_jobs (method.n_jobs) must be a non-zero integer (-1: every core), got {n_jobs!r}")
    executor = options.get("executor")
    if executor is not None and not hasattr(executor, "submit"):
        _refuse("emulator", f"executor must be a submitit executor "
                            f"(torchshm.make_executor(...)), got {type(executor).__name__}")


def first_point(problem: Any, method: str, seed: int, options: dict[str, Any]) -> np.ndarray:
    """`D` parameters: the first vector ``method`` evaluates with ``seed`` and ``options`` on a
    problem with no run yet (the centre of the plausible box for a method not known here)."""
    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    dim = plausible.shape[0]
    if method == "emcee":
        n_walkers = int(options.get("n_walkers", 40))
        return problem.sample_prior(n_walkers, np.random.default_rng([seed, 3]))[0]
    if method == "vbmc":
        from torchshm.inference.start import StartSettings, latin_design, vbmc_budget

        start = options.get("start") or StartSettings()
        if start.points is not None:
            return np.atleast_2d(np.asarray(start.points, dtype=np.float64))[0]
        settings = start.resolved(dim, vbmc_budget(dim, options))
        if settings.n_design:
            return latin_design(plausible, int(settings.n_design), seed)[0]
    if method == "emulator":
        from torchshm.inference.adaptive.acquisition import design

        n_phys = len(problem.physical_names)
        batch = int(options.get("batch_size", 5))
        n_initial = int(options.get("n_initial") or batch * -(-(2 * n_phys + 1) // batch))
        budget = options.get("max_model_evaluations")
        budget = max(15 * n_phys, n_initial + 2 * batch) if budget is None else int(budget)
        n = min(n_initial, max(budget, n_phys + 2))
        return design(plausible, n, seed)[0]
    return plausible.mean(axis=1)


def charge_check(method: str, options: dict[str, Any], dim: int, n_phys: int,
                 checked: int) -> dict[str, Any]:
    """``options`` with the output check's ``checked`` runs (0 or 1) taken from the method's
    budget (VBMC's ``max_fun_evals``, the emulator's ``max_model_evaluations``), so that the
    run stays within the budget given; unchanged where the budget has no run to spare."""
    if not checked:
        return options
    if method == "vbmc":
        from torchshm.inference.start import vbmc_budget

        n_initial = int(options.get("fun_eval_start") or 10 * -(-(dim + 1) // 10))
        budget = vbmc_budget(dim, options) - checked
        return {**options, "max_fun_evals": budget} if budget >= 2 * n_initial else options
    if method == "emulator":
        batch = int(options.get("batch_size", 5))
        n_initial = int(options.get("n_initial") or batch * -(-(2 * n_phys + 1) // batch))
        budget = options.get("max_model_evaluations")
        if budget is None:  # run_emulator's own default cap
            from torchshm.inference.adaptive.method import default_cap

            budget = default_cap(dim, n_initial, batch)
        budget = int(budget)
        return {**options, "max_model_evaluations": budget - checked} if budget > checked else options
    return options
