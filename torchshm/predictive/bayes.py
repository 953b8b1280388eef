"""Bayes factors from evidence lower bounds, with Jeffreys' scale (paper, Sec. 2.4.2, Tables 1, 9).

For models `i` and `j` with ELBOs ``E_i``, ``E_j`` (nats) used as log evidences::

    log10 B_ij = (E_i - E_j) / ln 10

with an interval ``log10 B_ij ± z sqrt(sd_i² + sd_j²) / ln 10`` from the ELBO standard
deviations (independent runs), and the label of Table 1 for ``B_ij``.
"""

from __future__ import annotations

import csv
import io
import math
import numbers
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Mapping

import numpy as np

if TYPE_CHECKING:
    from torchshm.inference.protocol import PosteriorLike

#: (upper end of log10 B, label) of Jeffreys' scale, Table 1
JEFFREYS: tuple[tuple[float, str], ...] = (
    (0.0, "Negative"),
    (0.5, "Barely worth mentioning"),
    (1.0, "Substantial"),
    (1.5, "Strong"),
    (2.0, "Very strong"),
    (math.inf, "Decisive"),
)


def jeffreys_label(log10_b: float) -> str:
    """Strength of evidence of Table 1 for a Bayes factor ``10**log10_b`` ("undefined" for NaN)."""
    if math.isnan(log10_b):
        return "undefined"
    for upper, label in JEFFREYS:
        if log10_b < upper:
            return label
    return JEFFREYS[-1][1]


@dataclass(frozen=True)
class BayesFactors:
    """Pairwise Bayes factors of `k` models; entry `[i, j]` is model `i` over model `j`.

    Attributes:
        names: `k` model names.
        log_evidence, log_evidence_sd: `k` ELBOs and their standard deviations [nats].
        log10: `k x k` log10 Bayes factors.
        lower, upper: `k x k` bounds of the interval of ``log10`` (NaN without sds).
        labels: `k x k` Jeffreys labels (``"–"`` on the diagonal).
    """

    names: list[str]
    log_evidence: np.ndarray
    log_evidence_sd: np.ndarray
    log10: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    labels: list[list[str]]

    def to_markdown(self, values: bool = True) -> str:
        """Table 9 as markdown: labels, with ``log10 B [lower, upper]`` when ``values``."""
        head = "| model | " + " | ".join(self.names) + " |"
        rule = "|---" * (len(self.names) + 1) + "|"
        rows = []
        for i, name in enumerate(self.names):
            cells = []
            for j in range(len(self.names)):
                cell = self.labels[i][j]
                if values and i != j:
                    cell += f" ({self.log10[i, j]:+.2f}"
                    cell += f" [{self.lower[i, j]:+.2f}, {self.upper[i, j]:+.2f}])" if np.isfinite(self.lower[i, j]) else ")"
                cells.append(cell)
            rows.append(f"| {name} | " + " | ".join(cells) + " |")
        return "\n".join([head, rule, *rows])

    def to_csv(self, path: str | Path | None = None) -> str:
        """Long-format CSV (one row per ordered pair); written to ``path`` when given."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["model_i", "model_j", "log10_B", "lower", "upper", "label"])
        for i, a in enumerate(self.names):
            for j, b in enumerate(self.names):
                if i != j:
                    writer.writerow([a, b, f"{self.log10[i, j]:.6g}", f"{self.lower[i, j]:.6g}",
                                     f"{self.upper[i, j]:.6g}", self.labels[i][j]])
        text = buffer.getvalue()
        if path is not None:
            Path(path).write_text(text)
        return text

    def __str__(self) -> str:
        return self.to_markdown()


def _evidence(name: str, item: PosteriorLike | tuple[float, float] | float) -> tuple[float, float]:
    """``(elbo, sd)`` of a posterior, an ``(elbo, sd)`` pair or a bare number."""
    if isinstance(item, numbers.Real):
        return float(item), math.nan
    if isinstance(item, (tuple, list)):
        elbo, sd = item
        if elbo is None:
            raise ValueError(f"bayes_factors: model {name!r} has no log evidence (an emcee posterior?)")
        return float(elbo), math.nan if sd is None else float(sd)
    elbo = getattr(item, "log_evidence", None)
    if elbo is None:
        raise ValueError(f"bayes_factors: model {name!r} has no log evidence (an emcee posterior?)")
    sd = getattr(item, "log_evidence_sd", None)
    return float(elbo), math.nan if sd is None else float(sd)


def bayes_factors(models: Mapping[str, PosteriorLike | tuple[float, float] | float], z: float = 1.96) -> BayesFactors:
    """Pairwise log10 Bayes factors from ELBOs and Jeffreys' labels (Table 9).

    Args:
        models: name -> posterior (``log_evidence``, ``log_evidence_sd``), or an
            ``(elbo, elbo_sd)`` pair, or a bare ELBO [nats]; at least two.
        z: half-width of the interval in standard deviations (1.96: about 95 %).

    Returns:
        A :class:`BayesFactors`.

    Raises:
        ValueError: with fewer than two models or a model without log evidence.
    """
    if len(models) < 2:
        raise ValueError(f"bayes_factors: need at least two models, got {len(models)}")
    names = list(models)
    pairs = [_evidence(name, models[name]) for name in names]
    elbo = np.array([p[0] for p in pairs])
    sd = np.array([p[1] for p in pairs])
    log10 = (elbo[:, None] - elbo[None, :]) / math.log(10.0)
    half = z * np.sqrt(sd[:, None] ** 2 + sd[None, :] ** 2) / math.log(10.0)
    labels = [["–" if i == j else jeffreys_label(log10[i, j]) for j in range(len(names))]
              for i in range(len(names))]
    return BayesFactors(names, elbo, sd, log10, log10 - half, log10 + half, labels)
