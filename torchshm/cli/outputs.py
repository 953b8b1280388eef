"""Files a ``torchshm-identify`` run writes into its run folder.

- ``posterior.nc``: the posterior (``torchshm.load_posterior`` reads it back);
- ``summary.csv``: mean, sd and 95 % interval per parameter (also printed); the posterior's
  warnings (``post.warnings``: not converged, mass at a prior bound, noise model) come first
  as ``#`` lines, only when there are any;
- ``corner.png``: 1-D and 2-D marginals, the truth marked when the data carry it; a red title
  names the warnings;
- ``elbo.png`` (VBMC): the ELBO per iteration; ``trace.png``: mean and 95 % interval of each
  parameter against evaluations, from ``post.history``;
- ``predictive.csv``: scores of the held-out load cases, per load case and sensor line (rows
  ``line="all"`` pool the lines); ``predictive.png``: one panel per line and load case, or for
  a field (`n x 2` coordinates) ``predictive_map_<load>.png`` per held-out load case: measured,
  predictive mean, 95 % width and where the measurement falls outside;
- ``run.json``: wall time, evaluations, evidence, convergence, warnings, the KL divergence
  (and where its density came from) and the settings;
- ``tb/``: TensorBoard events, written during inference by :func:`torchshm.identify`.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import math
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from torchshm.cli import plots

if TYPE_CHECKING:
    from torchshm.data.measurements import Measurements
    from torchshm.inference.posterior import Posterior

log = logging.getLogger(__name__)

#: abscissa of trace.png: VBMC history rows are per iteration, emcee rows per checkpoint
TRACE_AXES = (
    ("n_evaluations", "log-joint evaluations"),
    ("n_model_evaluations", "model runs (one point per round)"),
    ("n_samples", "samples (steps x walkers); statistics of the last window"),
)


def truths_of(attrs: Mapping[str, Any], names: list[str]) -> dict[str, float]:
    """True parameter values stored with synthetic data (``attrs["truth_<name>"]``)."""
    out = {}
    for name in names:
        value = attrs.get(f"truth_{name}")
        if isinstance(value, (int, float)) and math.isfinite(value):
            out[name] = float(value)
    return out


def history_traces(history: Mapping[str, np.ndarray], names: list[str]) -> dict[str, tuple]:
    """name -> (mean, q2.5, q97.5) per trace row, for the names the history holds."""
    return {
        n: (history[f"{n}/mean"], history[f"{n}/q2.5"], history[f"{n}/q97.5"])
        for n in names
        if f"{n}/mean" in history
    }


def write_posterior(post: Posterior, out_dir: Path, attrs: Mapping[str, Any],
                    labels: Mapping[str, str] | None = None) -> dict[str, Path]:
    """Posterior file, summary table (printed too) and figures of ``post`` in ``out_dir``.

    Args:
        post: the posterior.
        out_dir: the run folder.
        attrs: metadata of the measurements (``truth_<name>`` marks the corner plot).
        labels: axis label per parameter name (default: the names).
    """
    log.info("writing the posterior file, summary and figures to %s", out_dir)
    files = {"posterior": post.save(out_dir / "posterior.nc")}
    summary = post.summary()
    files["summary"] = out_dir / "summary.csv"
    summary.to_csv(files["summary"])
    print(post, flush=True)
    truths = truths_of(attrs, list(post.names))
    log.info("drawing the corner plot, ELBO and trace figures")
    files["corner"] = plots.corner_plot({post.method: post.samples}, post.names,
                                        out_dir / "corner.png", truths, labels=labels,
                                        warnings=post.warnings)
    history = post.history or {}
    if "elbo" in history and len(history["elbo"]):
        files["elbo"] = plots.elbo_plot(history, out_dir / "elbo.png")
    traces = history_traces(history, list(post.names))
    axis = next(((k, label) for k, label in TRACE_AXES if k in history), None)
    if traces and axis is not None:
        files["trace"] = plots.trace_plot(
            history[axis[0]], traces, out_dir / "trace.png", axis[1],
            f"{post.method}: mean and 95 % interval", labels=labels,
        )
    return files


def write_predictive(
    post: Posterior, held_out: Measurements | None, n: int, seed: int, out_dir: Path,
) -> tuple[list[dict[str, float]], dict[str, Path]]:
    """Posterior predictive of the held-out load cases: scores per load case and line, and
    figures (one panel per line, or maps of a field).

    A failure here does not fail the run (the posterior is already written): it is logged
    as a warning and no predictive files are written.
    """
    import torchshm
    from torchshm.predictive import metrics_table

    log.info("posterior predictive of the held-out load case(s) %s (%d draws)",
             [float(v) for v in held_out.loads], n)
    try:
        pred = torchshm.posterior_predictive(post, [float(v) for v in held_out.loads], n=n, seed=seed,
                                             keep="summary")  # scores and maps: float32 draws suffice
    except ValueError as err:
        log.warning("posterior predictive skipped: %s", err)
        return [], {}
    rows = metrics_table(pred, held_out)
    path = out_dir / "predictive.csv"
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for row in rows:
        log.info("held-out load %g m, line %s: %.1f %% inside the 95 %% interval, R2 %.3f, MSE %.3g",
                 row["load"], row["line"], 100 * row["coverage"], row["r2"], row["mse"])
    log.info("drawing the posterior predictive figure(s)")
    files = {"predictive": path}
    if np.ndim(held_out.x) == 2:
        for load in held_out.loads:
            files[f"predictive_map_{float(load):g}"] = plots.predictive_map(
                pred, held_out, float(load), out_dir / f"predictive_map_{float(load):g}.png")
    else:
        files["predictive_plot"] = plots.predictive_plot(pred, held_out, out_dir / "predictive.png")
    return rows, files


def write_run_record(result: Any, settings: Any) -> Path:
    """``run.json``: the numbers of the run and its settings."""
    post = result.posterior
    record = {
        "method": post.method,
        "names": list(post.names),
        "wall_time_s": result.wall_time_s,
        "n_model_evaluations": int(post.n_model_evaluations),
        "log_evidence": post.log_evidence,
        "log_evidence_sd": post.log_evidence_sd,
        "converged": bool(post.converged),
        "warnings": list(post.warnings),
        "summary": post.summary().as_dict(),
        "predictive": result.predictive,
        "information": information(post),
        "diagnostics": post.diagnostics,
        "settings": dataclasses.asdict(settings),
        "files": {k: str(v) for k, v in result.files.items()},
    }
    path = result.out_dir / "run.json"
    path.write_text(json.dumps(record, indent=2, default=_jsonable) + "\n")
    return path


#: posterior draws of the KL divergence in run.json
KL_DRAWS = 4000


def information(post: Posterior) -> dict[str, Any]:
    """The KL divergence prior -> posterior (:func:`torchshm.kl_divergence`, with its source)
    and whether a Bayes factor is defined (the method's log evidence), for ``run.json``.

    A KL that cannot be estimated gets its one-line reason (``kl_reason``) instead.
    """
    from torchshm.predictive import kl_divergence

    out: dict[str, Any] = {"evidence": (
        f"{post.method} log evidence" if post.log_evidence is not None
        else f"not defined: {post.method} computes no evidence")}
    try:
        kl = kl_divergence(post, n=KL_DRAWS, seed=0)
    except (ValueError, NotImplementedError) as err:
        return {**out, "kl": None, "kl_reason": str(err)}
    return {**out, "kl": float(kl), "kl_se": kl.se, "kl_source": kl.source,
            "kl_density_error": kl.density_error}


def _jsonable(value: Any) -> Any:
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, (np.generic,)):
        return value.item()
    if isinstance(value, (np.ndarray,)):
        return value.tolist()
    return str(value)


__all__ = ["history_traces", "information", "truths_of", "write_posterior", "write_predictive", "write_run_record"]
