"""Marginal summaries of posterior samples: mean, sd, 95 % interval and, for several chains,
ArviZ's bulk ESS and R-hat."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: the quantiles reported by :meth:`Posterior.summary` (the 95 % equal-tailed interval)
SUMMARY_QUANTILES = (0.025, 0.975)


@dataclass(frozen=True)
class SummaryRow:
    """Summary statistics of one parameter's marginal posterior (in the parameter's units)."""

    name: str
    mean: float
    sd: float
    q2_5: float
    q97_5: float
    ess_bulk: float | None = None
    r_hat: float | None = None


@dataclass(frozen=True)
class PosteriorSummary:
    """A table of marginal summaries, one row per parameter; printable and CSV-able.

    For several chains (emcee's walkers) the rows also carry ArviZ's bulk effective sample
    size and rank-normalised split R-hat, written as the columns ``ess_bulk`` and ``r_hat``.

    Attributes:
        rows: one :class:`SummaryRow` per inferred parameter, in the posterior's order.
        notes: one-line warnings of the run (:attr:`Posterior.warnings`), printed before the
            table and written as ``#`` comment lines at the top of the CSV.
    """

    rows: tuple[SummaryRow, ...]
    notes: tuple[str, ...] = ()

    COLUMNS = ("name", "mean", "sd", "q2.5", "q97.5")
    CHAIN_COLUMNS = ("ess_bulk", "r_hat")

    @property
    def has_chain_diagnostics(self) -> bool:
        """Whether the rows carry ESS and R-hat (a posterior of several chains)."""
        return bool(self.rows) and all(r.ess_bulk is not None for r in self.rows)

    def __getitem__(self, name: str) -> SummaryRow:
        """The row of parameter ``name``."""
        for row in self.rows:
            if row.name == name:
                return row
        raise KeyError(f"no parameter {name!r} in the summary; have {[r.name for r in self.rows]}")

    def to_csv(self, path: str | Path | None = None) -> str:
        """The table as CSV text (header ``name,mean,sd,q2.5,q97.5`` and, with several chains,
        ``ess_bulk,r_hat``), also written to ``path``. Each note comes first as a ``# `` line
        (read the file with ``pandas.read_csv(path, comment="#")``); without notes there are
        none."""
        chains = self.has_chain_diagnostics
        lines = [f"# {note}" for note in self.notes]
        lines += [",".join(self.COLUMNS + (self.CHAIN_COLUMNS if chains else ()))]
        lines += [
            f"{r.name},{r.mean:.10g},{r.sd:.10g},{r.q2_5:.10g},{r.q97_5:.10g}"
            + (f",{r.ess_bulk:.10g},{r.r_hat:.10g}" if chains else "")
            for r in self.rows
        ]
        text = "\n".join(lines) + "\n"
        if path is not None:
            Path(path).write_text(text)
        return text

    def as_dict(self) -> dict[str, dict[str, float]]:
        """``{name: {"mean", "sd", "q2.5", "q97.5"[, "ess_bulk", "r_hat"]}}``."""
        chains = self.has_chain_diagnostics
        return {
            r.name: {"mean": r.mean, "sd": r.sd, "q2.5": r.q2_5, "q97.5": r.q97_5,
                     **({"ess_bulk": r.ess_bulk, "r_hat": r.r_hat} if chains else {})}
            for r in self.rows
        }

    def __str__(self) -> str:
        return "\n".join([*self.notes, self.table()])

    def table(self) -> str:
        """The printed table alone, without the notes."""
        width = max([len("parameter")] + [len(r.name) for r in self.rows])
        chains = self.has_chain_diagnostics
        head = f"{'parameter':<{width}} {'mean':>11} {'sd':>11} {'q2.5':>11} {'q97.5':>11}"
        head += f" {'ess_bulk':>9} {'r_hat':>6}" if chains else ""
        body = [
            f"{r.name:<{width}} {r.mean:>11.4g} {r.sd:>11.4g} {r.q2_5:>11.4g} {r.q97_5:>11.4g}"
            + (f" {r.ess_bulk:>9.0f} {r.r_hat:>6.3f}" if chains else "")
            for r in self.rows
        ]
        return "\n".join([head, *body])


def summarize(names: list[str], samples: np.ndarray, n_chains: int = 1,
              notes: tuple[str, ...] = ()) -> PosteriorSummary:
    """Mean, sd and 2.5 % / 97.5 % quantiles of each column of ``samples`` (`S x D`).

    With ``n_chains > 1`` (``samples`` step-major, see :func:`as_chains`), also ArviZ's bulk
    ESS and rank-normalised split R-hat of each parameter. ``notes`` (one-line warnings) are
    carried into the summary, printed before its table.
    """
    samples = np.asarray(samples, dtype=np.float64)
    mean = samples.mean(axis=0)
    sd = samples.std(axis=0, ddof=1) if samples.shape[0] > 1 else np.zeros(len(names))
    lo, hi = np.quantile(samples, SUMMARY_QUANTILES, axis=0)
    ess: list[float | None] = [None] * len(names)
    rhat: list[float | None] = [None] * len(names)
    if n_chains > 1 and samples.shape[0] >= 4 * n_chains:
        import arviz as az

        chains = as_chains(samples, n_chains)
        ess = [float(az.ess(chains[..., i], method="bulk")) for i in range(len(names))]
        rhat = [float(az.rhat(chains[..., i])) for i in range(len(names))]
    rows = tuple(
        SummaryRow(n, float(m), float(s), float(a), float(b), e, r)
        for n, m, s, a, b, e, r in zip(names, mean, sd, lo, hi, ess, rhat)
    )
    return PosteriorSummary(rows, tuple(str(n) for n in notes))


def as_chains(values: np.ndarray, n_chains: int) -> np.ndarray:
    """Flat step-major values `S x ...` (row ``s * C + c`` is step ``s`` of chain ``c``) as
    `C x (S / C) x ...` (chain, draw)."""
    n_chains = max(1, int(n_chains))
    values = np.asarray(values)
    draws = values.shape[0] // n_chains
    return np.swapaxes(values.reshape(draws, n_chains, *values.shape[1:]), 0, 1)
