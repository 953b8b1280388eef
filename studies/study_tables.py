"""Tables of a study from the run folders of a ``torchshm-identify`` sweep (paper, Tables 8-13).

Each run folder holds ``run.json`` (written by the application: settings, evidence, summary,
held-out scores, optionally the KL divergence). :func:`read_sweep` turns every folder into a
:class:`RunRecord`; the table functions take a list of records and return markdown text.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from torchshm.predictive.bayes import BayesFactors, bayes_factors

#: parameter columns of Table 8, with units
PARAMETERS = (("E_c", "GPa"), ("log10_K_r", "log10 N·mm/rad"), ("sigma_a", "µε"), ("length", "m"))


@dataclass
class RunRecord:
    """What one run of a sweep produced (from its ``run.json``).

    Attributes:
        path: the run folder.
        kernel, resolution, method: the run's settings.
        inference_loads: load cases used for inference [m].
        log_evidence, log_evidence_sd: ELBO and its sd [nats] (None for emcee).
        summary: name -> {"mean", "sd", "q2.5", "q97.5"}.
        predictive: one dict per predicted load case (``load``, ``coverage``, ``r2``, ``mse``,
            ``mean_width``, ``n_points``).
        kl, kl_se: KL divergence from prior to posterior and its MC error [nats], if recorded.
        wall_time_s, n_model_evaluations, converged: run statistics.
    """

    path: Path
    kernel: str
    resolution: float | None
    method: str
    inference_loads: list[float]
    log_evidence: float | None
    log_evidence_sd: float | None
    summary: dict[str, dict[str, float]]
    predictive: list[dict[str, float]] = field(default_factory=list)
    kl: float | None = None
    kl_se: float | None = None
    wall_time_s: float = float("nan")
    n_model_evaluations: int = 0
    converged: bool = False

    @classmethod
    def from_json(cls, path: Path) -> RunRecord:
        """Read ``path / "run.json"``."""
        raw: dict[str, Any] = json.loads((path / "run.json").read_text())
        settings = raw.get("settings", {})
        return cls(
            path=path, kernel=str(settings["kernel"]["name"]),
            resolution=settings["data"].get("resolution"), method=str(raw["method"]),
            inference_loads=[float(v) for v in settings["data"]["loads"]],
            log_evidence=raw.get("log_evidence"), log_evidence_sd=raw.get("log_evidence_sd"),
            summary=raw["summary"], predictive=list(raw.get("predictive", [])),
            kl=raw.get("kl_divergence"), kl_se=raw.get("kl_divergence_se"),
            wall_time_s=float(raw.get("wall_time_s", float("nan"))),
            n_model_evaluations=int(raw.get("n_model_evaluations", 0)),
            converged=bool(raw.get("converged", False)),
        )

    def held_out_loads(self) -> list[float]:
        """Predicted load cases that were not used for inference, in prediction order."""
        return [float(r["load"]) for r in self.predictive
                if not any(abs(r["load"] - w) < 1e-6 for w in self.inference_loads)]

    def scores(self, loads: list[float] | None = None, held_out: bool | None = None) -> dict[str, float]:
        """Scores pooled over some predicted load cases (weighted by their points).

        Args:
            loads: load cases to pool; default chosen by ``held_out``.
            held_out: ``True`` for load cases not used for inference, ``False`` for inferred
                ones, ``None`` for all.

        Returns:
            ``coverage``, ``mse``, ``mean_width`` pooled, ``r2`` averaged, ``n_points``.
        """
        inferred = lambda v: any(abs(v - w) < 1e-6 for w in self.inference_loads)  # noqa: E731
        rows = [r for r in self.predictive
                if (loads is not None and any(abs(r["load"] - w) < 1e-6 for w in loads))
                or (loads is None and (held_out is None or inferred(r["load"]) != held_out))]
        if not rows:
            return {"coverage": np.nan, "mse": np.nan, "mean_width": np.nan, "r2": np.nan, "n_points": 0}
        w = np.array([r["n_points"] for r in rows], dtype=float)
        pool = lambda key: float(np.sum(w * np.array([r[key] for r in rows])) / w.sum())  # noqa: E731
        return {"coverage": pool("coverage"), "mse": pool("mse"), "mean_width": pool("mean_width"),
                "r2": float(np.mean([r["r2"] for r in rows])), "n_points": int(w.sum())}


def read_sweep(sweep_dir: str | Path) -> list[RunRecord]:
    """Records of every run folder (one holding ``run.json``) under ``sweep_dir``, sorted by path."""
    paths = sorted(p.parent for p in Path(sweep_dir).rglob("run.json"))
    return [RunRecord.from_json(p) for p in paths]


def order_records(records: list[RunRecord], key: Callable[[RunRecord], Any], order: list[Any] | None) -> list[RunRecord]:
    """``records`` sorted by the position of ``key(record)`` in ``order`` (unknown keys last)."""
    if order is None:
        return list(records)
    rank = {v: i for i, v in enumerate(order)}
    return sorted(records, key=lambda r: rank.get(key(r), len(rank)))


def parameter_table(records: list[RunRecord], label: Callable[[RunRecord], str]) -> str:
    """Table 8: posterior mean and 95 % interval of each parameter, one row per run."""
    head = "| run | " + " | ".join(f"{n} [{u}]" for n, u in PARAMETERS) + " |"
    lines = [head, "|---" * (len(PARAMETERS) + 1) + "|"]
    for rec in records:
        cells = []
        for name, _ in PARAMETERS:
            s = rec.summary.get(name)
            cells.append("–" if s is None else f"{s['mean']:.2f} [{s['q2.5']:.2f}, {s['q97.5']:.2f}]")
        lines.append(f"| {label(rec)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def evidence_table(records: list[RunRecord], label: Callable[[RunRecord], str]) -> BayesFactors:
    """Table 9: pairwise Bayes factors of the runs from their ELBOs."""
    return bayes_factors({label(r): (r.log_evidence, r.log_evidence_sd) for r in records})


def coverage_table(records: list[RunRecord], label: Callable[[RunRecord], str]) -> str:
    """Table 10: share of measurements inside the 95 % interval, inference vs unobserved data."""
    lines = ["| run | inference data | unobserved data |", "|---|---|---|"]
    for rec in records:
        inf, out = rec.scores(held_out=False), rec.scores(held_out=True)
        lines.append(f"| {label(rec)} | {100 * inf['coverage']:.2f} % | {100 * out['coverage']:.2f} % |")
    return "\n".join(lines)


def kl_table(records: list[RunRecord], label: Callable[[RunRecord], str]) -> str:
    """Table 12: KL divergence from prior to posterior [nats] with its Monte Carlo error."""
    lines = ["| run | D_KL [nats] |", "|---|---|"]
    for rec in records:
        value = "–" if rec.kl is None else f"{rec.kl:.2f} ± {rec.kl_se or 0.0:.2f}"
        lines.append(f"| {label(rec)} | {value} |")
    return "\n".join(lines)


def prediction_table(records: list[RunRecord], label: Callable[[RunRecord], str], load: float) -> str:
    """Table 13: R², MSE [µε²] and mean 95 % interval width [µε] at one held-out load case."""
    lines = ["| run | R² | MSE [µε²] | mean C.I. width [µε] |", "|---|---|---|---|"]
    for rec in records:
        s = rec.scores(loads=[load])
        lines.append(f"| {label(rec)} | {s['r2']:.3f} | {s['mse']:.3f} | {s['mean_width']:.3f} |")
    return "\n".join(lines)


def run_table(records: list[RunRecord], label: Callable[[RunRecord], str]) -> str:
    """Run statistics: model evaluations, convergence, ELBO and wall time."""
    lines = ["| run | model evaluations | converged | ELBO [nats] | wall time [s] |", "|---|---|---|---|---|"]
    for rec in records:
        elbo = "–" if rec.log_evidence is None else f"{rec.log_evidence:.2f} ± {rec.log_evidence_sd or 0:.2f}"
        lines.append(f"| {label(rec)} | {rec.n_model_evaluations} | {'yes' if rec.converged else 'no'} "
                     f"| {elbo} | {rec.wall_time_s:.0f} |")
    return "\n".join(lines)
