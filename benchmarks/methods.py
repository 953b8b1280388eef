"""The methods the suite compares, each run on a case's :class:`torchshm.Problem` the same way.

Every method sees the case's problem through a :class:`TimedModel`, which counts the distinct
parameter vectors sent to the forward model (model runs), the calls (for sequential rounds
with 5 workers: a call of ``b`` vectors is ``ceil(b / 5)`` rounds) and the CPU time spent in
the model, so that a method's own compute is its CPU time minus the model's.

Methods: ``emulator`` (``torchshm.identify(method="emulator")``, defaults), ``vbmc`` (PyVBMC
through ``torchshm.identify``, defaults), ``emcee`` (short, through ``torchshm.identify``) and
``gpry`` (GPry's ``Runner`` on the same log joint over the prior box, 5 points per
acquisition, its NORA acquisition with a cheaper nested sampling of the surrogate, its default
convergence rule, at most 40 evaluations per parameter; :data:`GPRY_ACQUISITION`).
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np

import torchshm

WORKERS = 5


class TimedModel:
    """A forward model that records its calls: rows per call and CPU seconds inside it."""

    def __init__(self, model: Any) -> None:
        self._model, self.calls, self.cpu_s = model, [], 0.0

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in ("_model", "calls", "cpu_s"):
            raise AttributeError(name)
        return getattr(self._model, name)

    def __call__(self, theta_p: Any) -> Any:
        t0 = time.process_time()
        out = self._model(theta_p)
        self.cpu_s += time.process_time() - t0
        shape = getattr(theta_p, "shape", (1,))
        self.calls.append(int(np.prod(shape[:-1])) if len(shape) > 1 else 1)
        return out

    @property
    def runs(self) -> int:
        """Distinct parameter vectors run (the problem never sends one twice)."""
        return int(sum(self.calls))

    def rounds(self, workers: int = WORKERS) -> int:
        """Sequential rounds with ``workers`` concurrent runs."""
        return int(sum(math.ceil(c / workers) for c in self.calls))


def weighted_moments(samples: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mean and sd `D` of samples `S x D` (optionally weighted)."""
    w = np.full(len(samples), 1.0 / len(samples)) if weights is None else weights / weights.sum()
    mean = w @ samples
    return mean, np.sqrt(w @ np.square(samples - mean))


def run_torchshm(problem: Any, method: str, quick: bool, seed: int,
                 extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """One ``torchshm.identify`` run (``extra``: more keyword options); moments, evidence,
    convergence and rounds."""
    options: dict[str, Any] = {}
    if method == "emulator" and quick:
        options = {"max_model_evaluations": 10, "n_walkers": 16, "n_steps": 60, "final_steps": 60,
                   "n_evidence": 500, "error_draws": 2}
    elif method == "vbmc":
        options = {"n_samples": 20000, **({"max_fun_evals": 30} if quick else {})}
    elif method == "emcee":
        options = {"n_walkers": 20, "n_steps": 60 if quick else 1000}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = torchshm.identify(problem, method=method, seed=seed, **{**options, **(extra or {})})
    mean, sd = weighted_moments(np.asarray(post.samples))
    out = {"mean": mean, "sd": sd, "log_z": post.log_evidence, "converged": bool(post.converged)}
    if method == "emulator":
        out["rounds"] = int(sum(math.ceil(r["n_new_runs"] / WORKERS) for r in post.diagnostics["rounds"]))
        out["evidence_ess"] = float(post.diagnostics["evidence_ess"])
        out["evidence_khat"] = float(post.diagnostics["evidence_khat"])
    return out


def prior_box(problem: Any, tail: float = 1e-4) -> np.ndarray:
    """`D x 2`: hard bounds, an infinite one replaced by the prior's ``1 - tail`` quantile."""
    box = np.array(problem.hard_bounds, dtype=float)
    for j, name in enumerate(problem.names):
        prior = problem.priors[name]
        if not np.isfinite(box[j, 0]):
            box[j, 0] = float(prior.ppf(np.array([tail]))[0])
        if not np.isfinite(box[j, 1]):
            box[j, 1] = float(prior.ppf(np.array([1 - tail]))[0])
    return box


#: GPry's settings here (see docs/benchmarks.md): its default NORA acquisition with a cheaper nested
#: sampling of the surrogate (live points capped at 10 per dimension instead of 50, slice chains of 2 per
#: dimension instead of 10: its candidate pool only), batches of 5, at most 40 evaluations per dimension, and
#: a final nested sampling of the surrogate with 25 live points per dimension, whose log Z is the row's.
GPRY_ACQUISITION = {"NORA": {"nlive_max": "10d", "num_repeats": "2d"}}
GPRY_FINAL_MC = {"nested": {"nlive": "25d", "num_repeats": "5d"}}
GPRY_MAX_TOTAL = "40d"


def run_gpry(problem: Any, quick: bool, seed: int) -> dict[str, Any]:
    """GPry on ``problem.log_joint`` over :func:`prior_box`, its initial points drawn from the
    plausible box (``ref_bounds``, as the other methods' designs); its log Z (of its final nested
    sampling of the surrogate) is mapped back to the problem's (GPry divides by the box volume)."""
    from gpry import Runner

    names, box = list(problem.names), prior_box(problem)
    holder: dict[str, Any] = {}
    per_iteration: dict[int, int] = {}  # GPry iteration (0: initial design) -> evaluations

    def loglike(x: np.ndarray) -> float:
        it = int(getattr(holder.get("runner"), "current_iteration", 0))
        per_iteration[it] = per_iteration.get(it, 0) + 1
        v = float(np.asarray(problem.log_joint(np.asarray(x, dtype=float)[None]))[0])
        return v if np.isfinite(v) else -np.inf

    options: dict[str, Any] = {"n_points_per_acq": WORKERS, "max_initial": GPRY_MAX_TOTAL, "max_total": GPRY_MAX_TOTAL}
    mc = GPRY_FINAL_MC
    if quick:
        options.update(n_initial=6, max_initial=11, max_total=11)  # one batch after the initial design
        mc = {"nested": {"nlive": "10d", "num_repeats": "2d"}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        runner = Runner(loglike, bounds=box.tolist(), ref_bounds=np.asarray(problem.plausible_bounds).tolist(),
                        params=names, gp_acquisition=GPRY_ACQUISITION, mc=mc, options=options, seed=seed,
                        verbose=1, plots=False)
        holder["runner"] = runner
        runner.run()
        samples = runner.last_mc_samples()
        if samples is None:
            runner.generate_mc_sample()
            samples = runner.last_mc_samples()
    mean, sd = weighted_moments(np.asarray(samples["X"]), None if samples["w"] is None else np.asarray(samples["w"]))
    log_z = runner.last_mc_logZ()
    return {"mean": mean, "sd": sd, "converged": bool(runner.has_converged),
            "log_z": None if log_z is None else float(log_z[0]) + float(np.log(box[:, 1] - box[:, 0]).sum()),
            "rounds": int(sum(math.ceil(n / WORKERS) for n in per_iteration.values()))}


def run_method(problem: Any, method: str, quick: bool = False, seed: int = 0,
               options: dict[str, Any] | None = None) -> dict[str, Any]:
    """Run ``method`` on ``problem`` (built on a :class:`TimedModel`; ``options``: more keyword
    options of a torchshm method); a failure is a row too."""
    timed: TimedModel = problem.model
    t0 = time.process_time()
    try:
        out = run_gpry(problem, quick, seed) if method == "gpry" else run_torchshm(problem, method, quick, seed,
                                                                                   options)
        out["error"] = ""
    except Exception as exc:  # noqa: BLE001 (the table records every method's failure)
        out = {"error": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"[:160],
               "converged": False}
    out["own_cpu_s"] = time.process_time() - t0 - timed.cpu_s
    out["runs"] = timed.runs
    out.setdefault("rounds", timed.rounds())
    return out
