"""Outputs of study A: Table 5, Figs. 4-6 and the convergence numbers.

Files written into the study folder:

- ``table5.csv`` / ``table5.md``: mean and sd per parameter for MCMC (A1) and VBMC (A2), with
  ``|mean_VBMC - mean_MCMC| / sd_MCMC`` and ``sd_VBMC / sd_MCMC``;
- ``fig4_corner.png``: both posteriors overlaid;
- ``fig5_emcee_convergence.png``: emcee mean and 95 % interval of the last ``window`` samples
  against the number of samples;
- ``fig6_vbmc_convergence.png``: VBMC mean and 95 % interval of each iteration's variational
  posterior against the number of evaluations;
- ``study_a.json`` / ``study_a.md``: evaluations, stabilisation points, wall times, diagnostics;
- ``vbmc_posterior.nc``, ``emcee_posterior.nc`` (``torchshm.load_posterior``) and
  ``emcee_chain.h5`` (the full chain, emcee's HDF5 backend).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from convergence import (
    MarginalComparison,
    compare_marginals,
    half_chain_means,
    stabilisation_point,
    window_stats,
)
from torchshm.cli import plots
from torchshm.cli.outputs import history_traces, truths_of

UNITS = {"E_c": "GPa", "log10_K_r": "log10 N·mm/rad", "sigma_a": "µε", "length": "m"}
#: tolerances [posterior sd] of the stabilisation sensitivity table
TOLERANCES = (0.05, 0.1, 0.2)


def write_table5(rows: list[MarginalComparison], out_dir: Path) -> None:
    """``table5.csv`` and ``table5.md``."""
    header = ["parameter", "unit", "mcmc_mean", "mcmc_sd", "vbmc_mean", "vbmc_sd",
              "abs_mean_diff_over_sd_mcmc", "sd_ratio_vbmc_over_mcmc"]
    values = [[r.name, UNITS.get(r.name, ""), r.mean_ref, r.sd_ref, r.mean, r.sd, r.mean_shift,
               r.sd_ratio] for r in rows]
    with open(out_dir / "table5.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([v[:2] + [f"{x:.6g}" for x in v[2:]] for v in values])
    lines = [
        "| Parameter | Unit | MCMC (A1) mean | MCMC sd | VBMC (A2) mean | VBMC sd | "
        "\\|Δmean\\|/sd_MCMC | sd_VBMC/sd_MCMC |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [f"| {v[0]} | {v[1]} | " + " | ".join(f"{x:.3g}" if i >= 4 else f"{x:.2f}"
                                                    for i, x in enumerate(v[2:])) + " |"
              for v in values]
    (out_dir / "table5.md").write_text("\n".join(lines) + "\n")


def stabilisation(n: np.ndarray, estimates: np.ndarray, final: np.ndarray, sd: np.ndarray) -> dict[str, float | None]:
    """:func:`stabilisation_point` at each tolerance of :data:`TOLERANCES`."""
    return {f"{tol:g}": stabilisation_point(n, estimates, final, sd, tol) for tol in TOLERANCES}


def vbmc_numbers(post: Any, tol: float) -> dict[str, Any]:
    """Evaluations to convergence and stabilisation of the VBMC run."""
    history = post.history
    names = list(post.names)
    means = np.column_stack([history[f"{n}/mean"] for n in names])
    summary = post.summary()
    final = np.array([summary[n].mean for n in names])
    sd = np.array([summary[n].sd for n in names])
    stab = stabilisation(history["n_evaluations"], means, final, sd)
    return {
        "converged": bool(post.converged),
        "iterations": int(history["iteration"][-1]) if len(history["iteration"]) else 0,
        "log_joint_evaluations_at_end": int(history["n_evaluations"][-1]),
        "model_evaluations": int(post.n_model_evaluations),
        "stabilised_at": stab[f"{tol:g}"],
        "stabilised_at_by_tol": stab,
        "elbo": post.log_evidence,
        "elbo_sd": post.log_evidence_sd,
    }


def emcee_numbers(post: Any, chain: np.ndarray, tol: float) -> dict[str, Any]:
    """Samples needed to stabilise and diagnostics of the emcee run."""
    n, means = half_chain_means(chain)
    summary = post.summary()
    names = list(post.names)
    final = means[-1]
    sd = np.array([summary[name].sd for name in names])
    stab = stabilisation(n, means, final, sd)
    d = post.diagnostics
    return {
        "converged": bool(post.converged),
        "samples_total": int(n[-1]),
        "model_evaluations": int(post.n_model_evaluations),
        "stabilised_at": stab[f"{tol:g}"],
        "stabilised_at_by_tol": stab,
        "acceptance_fraction": d.get("acceptance_fraction"),
        "tau_max_steps": d.get("tau_max"),
        "n_over_tau": d.get("n_over_tau"),
    }


def write_figures(vbmc: Any, emcee: Any, chain: np.ndarray, truths: Mapping[str, float],
                  numbers: Mapping[str, Any], window: int, out_dir: Path) -> None:
    """Figs. 4, 5 and 6 of the paper for this study."""
    names = list(vbmc.names)
    plots.corner_plot({"MCMC (emcee, A1)": emcee.samples, "VBMC (A2)": vbmc.samples}, names,
                      out_dir / "fig4_corner.png", truths)
    n, mean, lower, upper = window_stats(chain, window)
    stab = numbers["emcee"]["stabilised_at"]
    plots.trace_plot(
        n, {name: (mean[:, i], lower[:, i], upper[:, i]) for i, name in enumerate(names)},
        out_dir / "fig5_emcee_convergence.png", "samples (= log-joint evaluations)",
        f"emcee: mean and 95 % interval of the last {window} samples",
        {f"stabilised ({stab:.0f})": stab} if stab is not None else None,
    )
    end = numbers["vbmc"]["log_joint_evaluations_at_end"]
    plots.trace_plot(
        vbmc.history["n_evaluations"], history_traces(vbmc.history, names),
        out_dir / "fig6_vbmc_convergence.png", "log-joint evaluations",
        "VBMC: mean and 95 % interval of each iteration's posterior",
        {f"{'converged' if vbmc.converged else 'stopped'} ({end})": end},
    )


def write_report(vbmc_run: Any, emcee_run: Any, chain: np.ndarray, attrs: Mapping[str, Any],
                 budget: Any, out_dir: Path) -> dict[str, Any]:
    """Every output of study A (see the module docstring); returns the numbers."""
    vbmc, emcee = vbmc_run.posterior, emcee_run.posterior
    vbmc.save(out_dir / "vbmc_posterior.nc")
    emcee.save(out_dir / "emcee_posterior.nc")
    rows = compare_marginals(vbmc.names, emcee.samples, vbmc.samples)
    write_table5(rows, out_dir)
    numbers: dict[str, Any] = {
        "vbmc": {**vbmc_numbers(vbmc, budget.tol), "wall_time_s": vbmc_run.wall_time_s},
        "emcee": {**emcee_numbers(emcee, chain, budget.tol), "wall_time_s": emcee_run.wall_time_s},
        "comparison": {r.name: {"abs_mean_diff_over_sd_mcmc": r.mean_shift,
                                "sd_ratio_vbmc_over_mcmc": r.sd_ratio} for r in rows},
        "tolerance_sd": budget.tol,
        "window": budget.window,
        "truth": truths_of(attrs, list(vbmc.names)),
    }
    stab, end = numbers["emcee"]["stabilised_at"], numbers["vbmc"]["log_joint_evaluations_at_end"]
    numbers["emcee_samples_over_vbmc_evaluations"] = None if stab is None else stab / end
    write_figures(vbmc, emcee, chain, numbers["truth"], numbers, budget.window, out_dir)
    (out_dir / "study_a.json").write_text(json.dumps(numbers, indent=2) + "\n")
    (out_dir / "study_a.md").write_text(markdown(numbers, out_dir))
    return numbers


def _count(value: float | None) -> str:
    return "never within the run" if value is None else f"{value:.0f}"


def markdown(numbers: Mapping[str, Any], out_dir: Path) -> str:
    """A short human-readable report of the numbers, with Table 5."""
    v, e = numbers["vbmc"], numbers["emcee"]
    tol = numbers["tolerance_sd"]
    lines = [
        "# Study A: VBMC (A2) against emcee (A1)", "",
        (out_dir / "table5.md").read_text(), "",
        f"- VBMC: {'converged' if v['converged'] else 'did NOT converge'} after "
        f"{v['log_joint_evaluations_at_end']} log-joint evaluations ({v['iterations']} iterations, "
        f"{v['model_evaluations']} model evaluations with the start search, "
        f"{v['wall_time_s']:.0f} s); per-iteration means within {tol:g} sd of the final ones "
        f"from {_count(v['stabilised_at'])} evaluations.",
        f"- emcee: {e['samples_total']} samples ({e['model_evaluations']} model evaluations, "
        f"{e['wall_time_s']:.0f} s, acceptance {e['acceptance_fraction']:.2f}, "
        f"tau_max {e['tau_max_steps']:.1f} steps, converged: {e['converged']}); the mean of the "
        f"latest half of the chain stays within {tol:g} sd of its final value from "
        f"{_count(e['stabilised_at'])} samples.",
        "- stabilisation against the tolerance: "
        + "; ".join(f"{t} sd: emcee {_count(e['stabilised_at_by_tol'][t])} samples, VBMC "
                    f"{_count(v['stabilised_at_by_tol'][t])} evaluations"
                    for t in e["stabilised_at_by_tol"]) + ".",
    ]
    return "\n".join(lines) + "\n"


__all__ = ["emcee_numbers", "vbmc_numbers", "write_report", "write_table5"]
