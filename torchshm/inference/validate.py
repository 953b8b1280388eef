"""Every input of an identification checked before the first model run.

:func:`validate` is the first step of :func:`torchshm.identify` (and so of
``torchshm-identify``): the method's name, its options (names read from the method's runner
and the names the method passes through, e.g. PyVBMC's declared options; types and ranges), the problem's bounds and noise
levels. Each refusal is one ``ValueError`` line naming the input and the fix. Where the fix is
plain it is applied and said: parallel runs of a problem without a store get a store in the
run's folder. Then at most one model run checks the output's shape and dtype: the first point
the method would run anyway, through the problem's cache or store, so it is not spent twice.
"""

from __future__ import annotations

import difflib
import inspect
import logging
import math
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
import torch

from torchshm.inference.method_checks import check_method_options, first_point
from torchshm.inference.registry import get_method, method_names

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger(__name__)

#: the built-in method names (:func:`~torchshm.inference.registry.method_names` gives every
#: registered one)
METHODS = method_names()
#: keyword parameters of every runner that are not method options
_COMMON = ("problem", "seed", "log_dir")
#: option -> (kind, minimum): "int" an integer >= minimum, "float" a number > minimum; None is
#: accepted where the runner's default is None
_RANGES: dict[str, tuple[str, float]] = {
    "n_samples": ("int", 1), "n_walkers": ("int", 2), "n_steps": ("int", 1), "thin": ("int", 1),
    "burn": ("int", 0), "log_every": ("int", 1), "window": ("int", 1), "batch_size": ("int", 1),
    "max_model_evaluations": ("int", 0), "n_initial": ("int", 1), "final_steps": ("int", 1),
    "patience": ("int", 1), "n_evidence": ("int", 1), "max_iter": ("int", 1),
    "fun_eval_start": ("int", 1), "error_draws": ("int", 1), "tv_tol": ("float", 0.0), "sd_tol": ("float", 0.0),
}


def runner(method: str) -> Callable[..., Any]:
    """The function that runs ``method`` (:mod:`torchshm.inference.registry`)."""
    return get_method(method).run()


def check_method(method: object) -> None:
    """Refuse a method name that is not registered, listing the registered ones."""
    get_method(method)


def method_options(method: str) -> tuple[dict[str, Any], set[str] | None]:
    """``(options, pass_through)``: the keyword options of ``method``'s runner with their
    defaults, and the names its ``**options`` accept (PyVBMC's declared options for VBMC; None
    when any name passes)."""
    params = inspect.signature(runner(method)).parameters.values()
    named = {p.name: p.default for p in params
             if p.name not in _COMMON and p.kind is not inspect.Parameter.VAR_KEYWORD}
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params):
        return named, set()
    pass_through = get_method(method).pass_through
    return named, None if pass_through is None else pass_through()


def check_options(method: str, options: dict[str, Any], dim: int) -> None:
    """Refuse options ``method`` does not take, and values of the wrong type or range.

    Args:
        method: the method's name.
        options: the keyword options given to :func:`torchshm.identify`.
        dim: `D`, the number of inferred parameters.
    """
    named, extra = method_options(method)
    for key in options:
        if key in named or extra is None or key in extra:
            continue
        known = sorted(named) + sorted(extra)
        close = difflib.get_close_matches(key, known, n=1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        more = f" and {get_method(method).pass_through_doc}" if extra else ""
        raise ValueError(f"identify: method={method!r} has no option {key!r}; {hint}its options: "
                         f"{', '.join(sorted(named))}{more}")
    for key, value in options.items():
        if key in _RANGES and not (value is None and named.get(key, 0) is None):
            _check_range(method, key, value, *_RANGES[key])
    check_method_options(method, {**{k: v for k, v in named.items()
                                      if v is not inspect.Parameter.empty}, **options}, dim)


def _check_range(method: str, key: str, value: Any, kind: str, minimum: float) -> None:
    if kind == "int":
        ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= minimum
        want = f"an integer >= {minimum:g}"
    else:
        ok = (isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
              and math.isfinite(float(value)) and float(value) > minimum)
        want = f"a finite number > {minimum:g}"
    if not ok:
        raise ValueError(f"identify: method={method!r}: {key} (method.{key}) must be {want}, got {value!r}")


def check_problem(problem: Problem) -> None:
    """Refuse bounds and noise levels no method can work with (one-sided bounds are left to
    the methods): NaN or inverted bounds, a plausible box that is not finite or not inside the
    hard bounds, negative or non-finite σm, σe, and σm = σe = 0 with σa allowed to reach 0."""
    names = list(problem.names)
    hard = np.asarray(problem.hard_bounds, dtype=np.float64)
    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    for i, name in enumerate(names):
        (lo, hi), (plo, phi) = hard[i], plausible[i]
        fix = f"fix the prior of {name!r} (bounds=(lo, hi), plausible=(lo, hi))"
        if np.isnan(hard[i]).any() or not lo < hi:
            raise ValueError(f"identify: hard bounds of {name!r} are [{lo}, {hi}]; {fix}")
        if not (np.isfinite(plausible[i]).all() and plo < phi):
            raise ValueError(f"identify: plausible box of {name!r} is [{plo}, {phi}], not a finite "
                             f"interval; {fix}")
        if plo < lo or phi > hi:
            raise ValueError(f"identify: plausible box [{plo}, {phi}] of {name!r} is not inside its "
                             f"hard bounds [{lo}, {hi}]; {fix}")
    sigma_e = problem.sigma_e
    levels = {"sigma_m": problem.sigma_m, **({f"sigma_e[{k}]": v for k, v in sigma_e.items()}
                                             if isinstance(sigma_e, dict) else {"sigma_e": sigma_e})}
    levels = {k: v for k, v in levels.items() if not hasattr(v, "log_prob")}  # inferred: a prior
    for key, value in levels.items():
        if not (math.isfinite(float(value)) and float(value) >= 0):
            raise ValueError(f"identify: {key} is {value}; give a finite value >= 0")
    if (levels.get("sigma_m") == 0 and len(levels) > 1
            and all(float(v) == 0 for k, v in levels.items() if k != "sigma_m")):
        a_min = [hard[i, 0] for i, n in enumerate(names) if n.startswith("sigma_a")]
        fixed = [v for k, v in problem.priors.items() if k.startswith("sigma_a") and not hasattr(v, "log_prob")]
        if any(v <= 0 for v in a_min + fixed):
            raise ValueError("identify: sigma_e = sigma_m = 0 and sigma_a may be 0: the covariance "
                             "of Eq. (21) is then singular; give sigma_e > 0 (the sensor noise, µε)")


def ensure_store(problem: Problem, options: dict[str, Any], log_dir: str | Path | None) -> None:
    """Give a problem without a store one when ``options`` ask for parallel runs (``n_jobs`` !=
    1 or an ``executor``): ``<log_dir>/evaluations.sqlite``, else a new folder under ``runs/``;
    one log line says where."""
    parallel = options.get("n_jobs", 1) != 1 or options.get("executor") is not None
    if not parallel or problem.store is not None:
        return
    if log_dir is not None:
        folder = Path(log_dir)
    else:
        Path("runs").mkdir(exist_ok=True)
        folder = Path(tempfile.mkdtemp(prefix="store-", dir="runs"))
    path = folder / "evaluations.sqlite"
    problem.with_store(path)
    logger.warning("identify: parallel runs need a store, where each worker leaves its result; "
                   "this run keeps its model runs in %s (give the Problem store=... to choose)", path)


def check_model_output(problem: Problem, method: str, seed: int, options: dict[str, Any]) -> None:
    """Run the model once, at the first point ``method`` would run, and refuse an output of the
    wrong shape or dtype. Nothing is run when the problem (or its store) holds a run already.

    Raises:
        ValueError: naming the output's shape or dtype and the one expected.
    """
    theta_p, _ = problem.evaluations()
    runs_none = get_method(method).runs_none
    if len(theta_p) or (runs_none is not None and runs_none(options)):
        return  # a run is known already, or the method may run none
    point = torch.as_tensor(first_point(problem, method, seed, options), dtype=torch.float64)
    theta = problem.split.physical(point[None])
    out = problem.model_outputs(theta)
    if bool(torch.isfinite(out).all()):
        return
    failed, errors = problem.failures()
    for row, error in zip(np.asarray(failed)[::-1], errors[::-1]):
        if np.allclose(row, theta[0].numpy(), rtol=1e-10) and "model output has" in str(error) \
                and ("shape" in str(error) or "dtype" in str(error)):
            from torchshm.forward.protocol import output_shape

            shape = output_shape(problem.model)
            text = str(error).splitlines()[0].removeprefix("ValueError: ")
            raise ValueError(f"identify: {text}: the model must return float "
                             f"strains `... x L x n` = {shape} (model.loads x model.x) for θp "
                             f"`... x {len(problem.physical_names)}`")


def validate(problem: Problem, method: str, seed: int = 0, log_dir: str | Path | None = None,
             options: dict[str, Any] | None = None) -> None:
    """Every check of this module but the model run (:func:`check_model_output`, the next
    step), in order: method, options, problem; then the store parallel runs need.

    Args:
        problem: the :class:`~torchshm.Problem`.
        method: the method's name (a registered one, :func:`~torchshm.inference.registry.method_names`).
        seed: the run's seed.
        log_dir: the run's folder (TensorBoard), or None.
        options: the method's keyword options.

    Raises:
        ValueError: one line naming the input and the fix.
    """
    options = options or {}
    check_method(method)
    check_options(method, options, len(problem.names))
    check_problem(problem)
    ensure_store(problem, options, log_dir)
