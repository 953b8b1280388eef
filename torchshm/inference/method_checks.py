"""The checks of :mod:`torchshm.inference.validate` that belong to one method, through the
method registry (:mod:`torchshm.inference.registry`).

:func:`check_method_options` refuses, before any model run, the option values a method would
refuse only later (after its start-up search, or after its budget); :func:`first_point` is the
first parameter vector the method evaluates, where the one model run of the output check is
made so that the method finds it in the cache or store instead of running it again;
:func:`charge_check` takes that run from the method's budget.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

import torchshm.inference.methods  # noqa: F401  (registers the built-in methods)
from torchshm.inference.registry import get_method

if TYPE_CHECKING:
    from torchshm.problem import Problem


def check_method_options(method: str, options: dict[str, Any], dim: int) -> None:
    """Refuse what ``method`` would refuse later. ``options`` holds every option: the user's
    over the runner's defaults; ``dim`` is `D`, the number of inferred parameters."""
    check = get_method(method).check
    if check is not None:
        check(options, dim)


def first_point(problem: Problem, method: str, seed: int, options: dict[str, Any]) -> np.ndarray:
    """`D` parameters: the first vector ``method`` evaluates with ``seed`` and ``options`` on a
    problem with no run yet (the centre of the plausible box for a method that does not say)."""
    first = get_method(method).first_point
    if first is not None:
        return first(problem, seed, options)
    return np.asarray(problem.plausible_bounds, dtype=np.float64).mean(axis=1)


def charge_check(method: str, options: dict[str, Any], dim: int, n_phys: int,
                 checked: int) -> dict[str, Any]:
    """``options`` with the output check's ``checked`` runs (0 or 1) taken from the method's
    budget (VBMC's ``max_fun_evals``, the emulator's ``max_model_evaluations``), so that the
    run stays within the budget given; unchanged where the budget has no run to spare."""
    charge = get_method(method).charge
    if not checked or charge is None:
        return options
    return charge(options, dim, n_phys, checked)
