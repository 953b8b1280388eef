"""The comparison table a sweep (``torchshm-identify -m ...``) writes when its jobs are done.

Each job of a sweep writes ``run.json`` into its own folder. At the end of the multirun, the
Hydra callback :class:`SweepComparison` (listed in ``conf/config.yaml`` under
``hydra.callbacks``) reads them all and writes into the sweep folder:

- ``comparison.csv`` / ``comparison.md``: one row per job (named by the overrides that set it
  apart from the other jobs, e.g. ``kernel=matern52``): method, ELBO ± sd, log10 Bayes
  factor of the best job over this one with Jeffreys' label (paper, Tables 1 and 9), mean
  hold-out coverage of the 95 % predictive interval (over the load cases, all lines pooled),
  forward-model runs, convergence, the posterior's warnings (their tags: ``NOT CONVERGED``,
  ``PRIOR BOUND (E_c upper)``, ...), time, the KL divergence prior -> posterior with where its
  density came from (``posterior density`` or ``fitted mixture``, :func:`torchshm.kl_divergence`)
  and whether a Bayes factor is defined (the method's evidence, or why not);
- ``bayes_factors.csv``: every pair of jobs with an ELBO (:func:`torchshm.bayes_factors`).

A job without ``run.json`` (it failed) is listed as failed.
"""

from __future__ import annotations

import csv
import json
import logging
import math
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback
from omegaconf import DictConfig

log = logging.getLogger(__name__)

#: columns of comparison.csv
COLUMNS = ("job", "folder", "method", "elbo", "elbo_sd", "log10_B_best_over_job", "jeffreys",
           "holdout_coverage", "model_runs", "converged", "warnings", "wall_time_s", "status", "kl",
           "kl_se", "kl_source", "bayes_factor")


def job_overrides(folder: Path) -> list[str]:
    """The command-line overrides of a job (``.hydra/overrides.yaml``; empty if unreadable)."""
    import yaml

    try:
        items = yaml.safe_load((folder / ".hydra" / "overrides.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return []
    return [str(i) for i in items] if isinstance(items, list) else []


def job_names(folders: list[Path]) -> list[str]:
    """Name of each job: its overrides that not every job shares (e.g. ``kernel=matern52``),
    else its folder name."""
    overrides = [job_overrides(f) for f in folders]
    shared = set.intersection(*(set(o) for o in overrides)) if overrides else set()
    names = [",".join(o for o in items if o not in shared) for items in overrides]
    return [n or f.name for n, f in zip(names, folders)]


def job_row(folder: Path, name: str | None = None) -> dict[str, Any]:
    """One row of the table from ``folder/run.json`` (status ``failed`` without it)."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS, "")
    row["job"] = name or folder.name
    row["folder"] = folder.name
    path = folder / "run.json"
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        row["status"] = "failed"
        return row
    from torchshm.inference.checks import warning_tags  # the methods' libraries: not at Hydra's start

    coverage = [p["coverage"] for p in record.get("predictive") or []
                if "coverage" in p and p.get("line", "all") == "all"]
    info = record.get("information") or {}
    row.update(
        method=record.get("method", ""),
        elbo=record.get("log_evidence"),
        elbo_sd=record.get("log_evidence_sd"),
        holdout_coverage=sum(coverage) / len(coverage) if coverage else None,
        model_runs=record.get("n_model_evaluations"),
        converged=record.get("converged"),
        warnings=warning_tags(record.get("warnings") or []),
        wall_time_s=record.get("wall_time_s"),
        status="ok",
        kl=info.get("kl"),
        kl_se=info.get("kl_se"),
        kl_source=info.get("kl_source") or info.get("kl_reason", ""),
        bayes_factor=info.get("evidence", ""),
    )
    return row


def compare_runs(sweep_dir: Path) -> dict[str, Path]:
    """Write the comparison of every job folder of ``sweep_dir``; returns the files written.

    Raises:
        ValueError: when ``sweep_dir`` holds no job folder.
    """
    import torchshm

    folders = sorted(p for p in Path(sweep_dir).iterdir() if p.is_dir() and (p / ".hydra").is_dir())
    if not folders:
        raise ValueError(f"sweep {sweep_dir}: no job folder")
    rows = [job_row(f, n) for f, n in zip(folders, job_names(folders))]
    with_elbo = {r["job"]: (float(r["elbo"]), _float(r["elbo_sd"])) for r in rows
                 if isinstance(r["elbo"], (int, float)) and math.isfinite(r["elbo"])}
    files = {}
    if len(with_elbo) >= 2:
        bf = torchshm.bayes_factors(with_elbo)
        best = int(max(range(len(bf.names)), key=lambda i: bf.log_evidence[i]))
        for row in rows:
            if row["job"] in with_elbo:
                j = bf.names.index(row["job"])
                row["log10_B_best_over_job"] = 0.0 if j == best else float(bf.log10[best, j])
                row["jeffreys"] = "best" if j == best else bf.labels[best][j]
        files["bayes_factors"] = Path(sweep_dir) / "bayes_factors.csv"
        bf.to_csv(files["bayes_factors"])
    files["csv"] = Path(sweep_dir) / "comparison.csv"
    with open(files["csv"], "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(COLUMNS))
        writer.writeheader()
        writer.writerows({k: _cell(v) for k, v in r.items()} for r in rows)
    files["markdown"] = Path(sweep_dir) / "comparison.md"
    files["markdown"].write_text(_markdown(rows))
    return files


def _markdown(rows: list[dict[str, Any]]) -> str:
    head = ("| job | method | ELBO [nats] | log10 B (best / job) | Jeffreys | hold-out coverage "
            "| model runs | converged | warnings | status | KL [nats] | KL from | Bayes factor |")
    lines = [head, "|---" * 13 + "|"]
    for r in rows:
        elbo = "" if r["elbo"] in ("", None) else f"{r['elbo']:.2f}"
        if elbo and r["elbo_sd"] not in ("", None):
            elbo += f" ± {r['elbo_sd']:.2f}"
        bf = "" if r["log10_B_best_over_job"] == "" else f"{r['log10_B_best_over_job']:.2f}"
        cov = "" if r["holdout_coverage"] in ("", None) else f"{100 * r['holdout_coverage']:.1f} %"
        lines.append(f"| {r['job']} | {r['method']} | {elbo} | {bf} | {r['jeffreys']} | {cov} "
                     f"| {_cell(r['model_runs'])} | {_cell(r['converged'])} | {r['warnings']} "
                     f"| {r['status']} | {_kl(r)} | {r['kl_source']} | {r['bayes_factor']} |")
    return "\n".join(lines) + "\n"


def _kl(row: dict[str, Any]) -> str:
    if not isinstance(row["kl"], (int, float)):
        return ""
    return f"{row['kl']:.2f}" + (f" ± {row['kl_se']:.2f}" if isinstance(row["kl_se"], (int, float)) else "")


def _float(value: Any) -> float:
    return float(value) if isinstance(value, (int, float)) else math.nan


def _cell(value: Any) -> Any:
    return "" if value is None else value


class SweepComparison(Callback):
    """Hydra callback: :func:`compare_runs` on the sweep folder at the end of a multirun."""

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        try:
            files = compare_runs(sweep_dir)
        except (OSError, ValueError) as err:  # never fail a finished sweep for its summary
            log.warning("no sweep comparison: %s", err)
            return
        log.info("sweep comparison: %s", files["markdown"])
        print(files["markdown"].read_text(), flush=True)


__all__ = ["COLUMNS", "SweepComparison", "compare_runs", "job_names", "job_overrides", "job_row"]
