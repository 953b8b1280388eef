"""The result of an identification: posterior samples, density, evidence and diagnostics.

A :class:`Posterior` is what :func:`torchshm.identify` returns, for VBMC and emcee alike. It
keeps the samples, the variational density (VBMC only), the evidence lower bound (VBMC only),
the per-iteration trace and the run's diagnostics, and it is saved to and loaded from a single
netCDF file (see :mod:`torchshm.inference.netcdf`).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torchshm.problem.prior import JointPrior

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


@dataclass(frozen=True)
class PosteriorSummary:
    """A table of marginal summaries, one row per parameter; printable and CSV-able.

    Attributes:
        rows: one :class:`SummaryRow` per inferred parameter, in the posterior's order.
    """

    rows: tuple[SummaryRow, ...]

    COLUMNS = ("name", "mean", "sd", "q2.5", "q97.5")

    def __getitem__(self, name: str) -> SummaryRow:
        """The row of parameter ``name``."""
        for row in self.rows:
            if row.name == name:
                return row
        raise KeyError(f"no parameter {name!r} in the summary; have {[r.name for r in self.rows]}")

    def to_csv(self, path: str | Path | None = None) -> str:
        """The table as CSV text (header ``name,mean,sd,q2.5,q97.5``), also written to ``path``."""
        lines = [",".join(self.COLUMNS)]
        lines += [
            f"{r.name},{r.mean:.10g},{r.sd:.10g},{r.q2_5:.10g},{r.q97_5:.10g}" for r in self.rows
        ]
        text = "\n".join(lines) + "\n"
        if path is not None:
            Path(path).write_text(text)
        return text

    def as_dict(self) -> dict[str, dict[str, float]]:
        """``{name: {"mean", "sd", "q2.5", "q97.5"}}``."""
        return {
            r.name: {"mean": r.mean, "sd": r.sd, "q2.5": r.q2_5, "q97.5": r.q97_5}
            for r in self.rows
        }

    def __str__(self) -> str:
        width = max([len("parameter")] + [len(r.name) for r in self.rows])
        head = f"{'parameter':<{width}} {'mean':>11} {'sd':>11} {'q2.5':>11} {'q97.5':>11}"
        body = [
            f"{r.name:<{width}} {r.mean:>11.4g} {r.sd:>11.4g} {r.q2_5:>11.4g} {r.q97_5:>11.4g}"
            for r in self.rows
        ]
        return "\n".join([head, *body])


def summarize(names: list[str], samples: np.ndarray) -> PosteriorSummary:
    """Mean, sd and 2.5 % / 97.5 % quantiles of each column of ``samples`` (`S x D`)."""
    samples = np.asarray(samples, dtype=np.float64)
    mean = samples.mean(axis=0)
    sd = samples.std(axis=0, ddof=1) if samples.shape[0] > 1 else np.zeros(len(names))
    lo, hi = np.quantile(samples, SUMMARY_QUANTILES, axis=0)
    rows = tuple(
        SummaryRow(n, float(m), float(s), float(a), float(b))
        for n, m, s, a, b in zip(names, mean, sd, lo, hi)
    )
    return PosteriorSummary(rows)


@dataclass
class Posterior:
    """Posterior of an identification run (see ``docs/inference.md``).

    Attributes:
        names: the `D` inferred parameter names, physical first, then statistical.
        method: ``"vbmc"`` or ``"emcee"``.
        samples: `S x D` posterior samples (VBMC: drawn from the variational posterior; emcee:
            the chain after burn-in and thinning, flattened step-major: row ``s * W + w`` is
            step ``s`` of walker ``w``).
        log_evidence: the ELBO [nats] for VBMC; None for emcee.
        log_evidence_sd: standard deviation of the ELBO estimate [nats]; None for emcee.
        n_model_evaluations: forward-model calls this run made (store hits excluded).
        converged: whether the method's own convergence check passed.
        diagnostics: scalars describing the run (evaluations, wall time, tau, acceptance...).
        priors: dict name -> prior or fixed value, as the problem used them.
        history: per-iteration (VBMC) or per-checkpoint (emcee) trace: 1-D arrays keyed
            ``"iteration"``, ``"n_evaluations"``, ... and ``"<name>/mean"``, ``"<name>/q2.5"``,
            ``"<name>/q97.5"``.
        sample_stats: per-sample statistics, arrays `S` aligned with :attr:`samples` (emcee:
            ``lp``, the log joint of each sample).
        variational: the PyVBMC ``VariationalPosterior`` (VBMC only), used by :meth:`log_pdf`.
        n_chains: chains behind ``samples`` (emcee: walkers; VBMC: 1).
        problem: the :class:`~torchshm.Problem` it came from (not saved; None after loading).
    """

    names: list[str]
    method: str
    samples: np.ndarray
    log_evidence: float | None = None
    log_evidence_sd: float | None = None
    n_model_evaluations: int = 0
    converged: bool = False
    diagnostics: dict[str, Any] = field(default_factory=dict)
    priors: dict[str, Any] = field(default_factory=dict)
    history: dict[str, np.ndarray] = field(default_factory=dict)
    sample_stats: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    variational: Any = field(default=None, repr=False)
    n_chains: int = 1
    problem: Any = field(default=None, repr=False, compare=False)

    @property
    def prior(self) -> JointPrior:
        """The joint prior of :attr:`names` (the problem's when attached, else from :attr:`priors`)."""
        if self.problem is not None:
            return self.problem.prior
        return JointPrior(self.priors, self.names)

    @property
    def n_samples(self) -> int:
        """Number of stored samples `S`."""
        return int(self.samples.shape[0])

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """Draw ``n`` parameter vectors from the posterior.

        VBMC draws fresh samples from the variational posterior; emcee resamples the stored
        chain (without replacement when ``n <= S``, with replacement otherwise).

        Args:
            n: number of draws.
            rng: generator or seed; None for a fresh unseeded generator.

        Returns:
            `n x D` float64 array, columns in the order of :attr:`names`.
        """
        rng = np.random.default_rng(rng)
        if self.variational is not None:
            vp = copy.deepcopy(self.variational)
            vp.rng = rng  # a copy shares the generator of the original: replace it
            draws, _ = vp.sample(int(n))
            return np.asarray(draws, dtype=np.float64)
        replace = int(n) > self.n_samples
        idx = rng.choice(self.n_samples, size=int(n), replace=replace)
        return self.samples[idx].copy()

    def log_pdf(self, theta: np.ndarray) -> np.ndarray:
        """Log density of the (variational) posterior at ``theta``.

        Args:
            theta: `... x D` parameter vectors in the order of :attr:`names`.

        Returns:
            `...` log densities [nats]; -inf outside the hard bounds.

        Raises:
            NotImplementedError: for an emcee posterior, which has samples but no density.
        """
        if self.variational is None:
            raise NotImplementedError(
                f"a {self.method!r} posterior has samples but no density; use method='vbmc' for "
                "log_pdf, or fit a density (e.g. a kernel density estimate) to post.samples"
            )
        theta = np.asarray(theta, dtype=np.float64)
        flat = theta.reshape(-1, len(self.names))
        values = np.asarray(self.variational.pdf(flat, log_flag=True), dtype=np.float64)
        return values.reshape(theta.shape[:-1])

    def summary(self) -> PosteriorSummary:
        """Mean, sd and 95 % equal-tailed interval of each parameter, from :attr:`samples`."""
        return summarize(self.names, self.samples)

    def save(self, path: str | Path) -> Path:
        """Write the posterior to one netCDF file (InferenceData-style groups); returns the path."""
        from torchshm.inference.netcdf import save_posterior

        return save_posterior(self, path)

    def __str__(self) -> str:
        ev = (
            f"ELBO {self.log_evidence:.3f} +/- {self.log_evidence_sd:.3f}"
            if self.log_evidence is not None and self.log_evidence_sd is not None
            else "no evidence estimate"
        )
        state = "converged" if self.converged else "NOT converged"
        head = (
            f"Posterior ({self.method}, {state}, {self.n_model_evaluations} model evaluations, "
            f"{ev})"
        )
        return f"{head}\n{self.summary()}"
