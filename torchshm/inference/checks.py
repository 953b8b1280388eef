"""Checks of a finished fit, run by :func:`torchshm.identify` after every method.

:func:`check_fit` adds to ``post.warnings`` one line per problem, each naming the cause and the
fix, and to ``post.diagnostics`` the numbers behind them. No check runs the forward model.

- ``NOT CONVERGED``: the method's own convergence test failed (what it reported, what to raise).
- ``FAILED RUNS`` / ``STUCK WALKERS``: model runs that failed, emcee walkers that barely moved.
- ``PRIOR BOUND``: posterior mass piled at a finite hard bound of a parameter
  (:func:`bound_shares`).
- ``EXTRAPOLATION``: an emulator's posterior reaching past every model run
  (:func:`extrapolation_lines`).
- ``EVIDENCE``: the emulator's importance sampling kept too few effective draws, so its draws
  are the chain's and its log evidence is unreliable, or it left a moment uncertain
  (:func:`evidence_line`).
- ``NOISE MODEL``: the measured strains contradict the assumed noise levels
  (:mod:`torchshm.inference.noise_check`).
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

import torchshm.inference.methods  # noqa: F401  (registers the built-in methods)
from torchshm.inference.adaptive.draws import MOMENT_WARN
from torchshm.inference.adaptive.final import EXTRAPOLATION_SHARE  # warn at this share beyond the runs
from torchshm.inference.noise_check import noise_check
from torchshm.inference.registry import find_method
from torchshm.inference.vbmc_check import misfit_line
from torchshm.problem.parameters import statistical_base

if TYPE_CHECKING:
    from torchshm.inference.posterior import Posterior

#: share of the hard range at each finite end inspected by the bound check
EDGE = 0.02
#: warn when the posterior puts this many times what a flat posterior would (``EDGE``) there
BOUND_FACTOR = 3.0


def check_fit(post: Posterior) -> Posterior:
    """Add the warnings and diagnostics of every check to ``post`` (in place); returns it.

    A line already in ``post.warnings`` is not added twice, so checking again is harmless.
    """
    lines = [convergence_line(post), *run_lines(post)]
    shares = bound_shares(post)
    for (name, end), (share, bound) in shares.items():
        post.diagnostics[f"bound_share/{name}/{end}"] = share
        if share >= BOUND_FACTOR * EDGE:
            lines.append(bound_line(name, end, bound, share))
    lines += extrapolation_lines(post)
    lines.append(misfit(post))
    lines.append(evidence_line(post))
    try:
        noise_line, numbers = noise_check(post)
    except Exception as err:  # noqa: BLE001 - a check must never cost a finished posterior
        warnings.warn(f"the noise-model check was skipped: {type(err).__name__}: {err}",
                      RuntimeWarning, stacklevel=3)
        noise_line, numbers = None, {}
    post.diagnostics.update(numbers)
    lines.append(noise_line)
    for line in lines:
        if line and line not in post.warnings:
            post.warnings.append(line)
    return post


def convergence_line(post: Posterior) -> str | None:
    """``"NOT CONVERGED: ..."`` with what the method reported and what to raise, or None."""
    if post.converged:
        return None
    method = find_method(post.method)
    if method is not None and method.not_converged is not None:
        return method.not_converged(post)
    return (f"NOT CONVERGED: method {post.method!r} reported no convergence: raise its budget "
            f"and rerun on the same store (finished model runs are reused)")


def run_lines(post: Posterior) -> list[str]:
    """Failed model runs and stuck emcee walkers, as warning lines."""
    d, out = post.diagnostics, []
    failed = int(d.get("n_failed_evaluations", 0) or 0)
    if failed:
        out.append(f"FAILED RUNS: {failed} model runs failed and were "
                   f"{_failed_runs(post.method)}; "
                   "see problem.failures() for their errors and fix the model or the bounds")
    stuck = int(d.get("n_stuck_walkers", 0) or 0)
    if stuck:
        out.append(f"STUCK WALKERS: {stuck} of {d.get('n_walkers', '?')} emcee walkers barely "
                   "moved (diagnostics['stuck_walkers']); their samples bias the posterior: run "
                   "more steps or start the walkers elsewhere")
    return out


def extrapolation_lines(post: Posterior) -> list[str]:
    """``EXTRAPOLATION`` lines: an emulator's posterior reaching past every model run
    (``diagnostics["beyond_runs"]``, :func:`torchshm.inference.adaptive.final.beyond_runs`)."""
    d, out = post.diagnostics, []
    ranges = d.get("runs_range", {})
    for name, share in (d.get("beyond_runs") or {}).items():
        if share >= EXTRAPOLATION_SHARE:
            low, high = ranges.get(name, (math.nan, math.nan))
            out.append(f"EXTRAPOLATION: {share:.0%} of the posterior of {name} lies beyond every "
                       f"model run ({name} {low:.4g} to {high:.4g}): there the emulator extends "
                       "what it saw and can miss a peak it never ran. Fix: rerun on the same "
                       "store with a larger max_model_evaluations or n_initial, or a plausible "
                       "box that covers where the posterior lies (finished runs are reused)")
    return out


def misfit(post: Posterior) -> str | None:
    """``VBMC MISFIT``: a VBMC posterior that underweights points of its bulk that VBMC
    evaluated (``diagnostics["misfit"]``, :mod:`torchshm.inference.vbmc_check`)."""
    return misfit_line(post.diagnostics) if post.diagnostics.get("misfit") else None


def evidence_line(post: Posterior) -> str | None:
    """``EVIDENCE``: the emulator's final importance sampling fell back to the chain
    (``diagnostics["posterior_draws"] == "chain"``), or its passes left a posterior mean or sd
    with a Monte Carlo error above :data:`~torchshm.inference.adaptive.draws.MOMENT_WARN` of an
    sd (:func:`torchshm.inference.adaptive.draws.posterior_draws`)."""
    d = post.diagnostics
    error = float(d.get("draws_moment_error", math.nan))
    if d.get("posterior_draws") == "importance" and error > MOMENT_WARN:
        return (f"EVIDENCE: after {int(d.get('importance_passes', 0)) + 1} passes of importance "
                f"sampling a posterior mean or sd of the emulator's draws still has a Monte Carlo "
                f"error of {error:.2g} of an sd (a tail that few draws reach). Fix: rerun on the "
                "same store with a larger n_evidence (no new model runs)")
    if d.get("posterior_draws") != "chain":
        return None
    return (f"EVIDENCE: importance sampling of the emulated posterior kept "
            f"{float(d.get('evidence_ess', 0.0)):.0f} effective draws, too few: the posterior "
            "draws are the emulator chain's (the shares of several modes are the chain's) and "
            "the log evidence and Bayes factors are unreliable. Fix: rerun on the same store "
            "with larger final_steps and n_evidence (no new model runs)")


def _failed_runs(name: str) -> str:
    """What the method does with a failed run (its registration says)."""
    method = find_method(name)
    return "left out" if method is None else method.failed_runs


def bound_shares(post: Posterior) -> dict[tuple[str, str], tuple[float, float]]:
    """Share of the samples in the outermost :data:`EDGE` of the hard range at each finite end.

    A flat posterior puts ``EDGE`` (2 %) there, a well-identified interior one about 0. A
    range with one infinite end is measured on the plausible range's width. The lower bound 0
    of a scale (``sigma_a``, an inferred ``sigma_m`` or ``sigma_e``) is left out: no model
    error, or no noise of that kind, is a legitimate answer.

    Returns:
        ``(name, "lower" | "upper") -> (share, bound)`` for every finite bound checked.
    """
    samples = np.asarray(post.samples, dtype=np.float64)
    if samples.ndim != 2 or samples.shape[0] == 0:
        return {}
    prior = post.prior
    hard, plausible = np.asarray(prior.hard_bounds), np.asarray(prior.plausible_bounds)
    out: dict[tuple[str, str], tuple[float, float]] = {}
    for i, name in enumerate(post.names):
        lo, hi = (float(v) for v in hard[i])
        width = hi - lo if math.isfinite(hi - lo) else float(plausible[i, 1] - plausible[i, 0])
        edge, x = EDGE * width, samples[:, i]
        if math.isfinite(lo) and not (_is_scale(name) and lo == 0.0):
            out[(name, "lower")] = (float(np.mean(x <= lo + edge)), lo)
        if math.isfinite(hi):
            out[(name, "upper")] = (float(np.mean(x >= hi - edge)), hi)
    return out


def _is_scale(name: str) -> bool:
    """Whether ``name`` is a discrepancy scale or an inferred noise level."""
    return statistical_base(name) == "sigma_a" or name in ("sigma_m", "sigma_e")


def bound_line(name: str, end: str, bound: float, share: float) -> str:
    """The ``PRIOR BOUND`` warning of one parameter end."""
    return (f"PRIOR BOUND: {name} piles at its {end} prior bound {bound:g}: {share:.0%} of the "
            f"posterior lies in the outermost {EDGE:.0%} of its range (a flat posterior: "
            f"{EDGE:.0%}). Causes: the data cannot tell values beyond apart (a saturating "
            "parameter), the prior is too narrow, or the noise model is wrong. Fix: widen the "
            "bound if values beyond are possible, else report the parameter as bounded, not "
            "identified; a modulus at a bound: check the noise model (sigma_m, sigma_e) first")


def warning_tags(lines: list[str] | tuple[str, ...], parameters: bool = True) -> str:
    """Short form of warning lines for a table cell or a title: ``"NOT CONVERGED; PRIOR BOUND
    (E_c upper)"``."""
    tags: list[str] = []
    for line in lines:
        tag, _, rest = str(line).partition(":")
        if parameters and tag == "PRIOR BOUND":
            words = rest.split()
            tag = f"{tag} ({words[0]} {words[4]})" if len(words) > 4 else tag
        if tag not in tags:
            tags.append(tag)
    return "; ".join(tags)


__all__ = ["BOUND_FACTOR", "EDGE", "EXTRAPOLATION_SHARE", "bound_line", "bound_shares",
           "check_fit", "convergence_line", "evidence_line", "extrapolation_lines", "misfit", "run_lines",
           "warning_tags"]
