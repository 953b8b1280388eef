"""The result of an identification: posterior samples, density, evidence and diagnostics.

A :class:`Posterior` is what :func:`torchshm.identify` returns, for VBMC and emcee alike. It
keeps the samples, the variational density (VBMC only), the evidence lower bound (VBMC only),
the per-iteration trace and the run's diagnostics, and it is saved to and loaded from a single
netCDF file (see :mod:`torchshm.inference.netcdf`).
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from torchshm.inference.summary import (
    SUMMARY_QUANTILES,
    PosteriorSummary,
    SummaryRow,
    as_chains,
    summarize,
)
from torchshm.problem.prior import JointPrior

__all__ = ["SUMMARY_QUANTILES", "Posterior", "PosteriorSummary", "SummaryRow", "as_chains",
           "summarize"]

if TYPE_CHECKING:
    from torchshm.problem import Problem
    from pyvbmc import VariationalPosterior
    import arviz as az

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
        warnings: one line per problem found with the result, each naming the cause and the
            fix: ``"NOT CONVERGED: ..."`` for a run that did not converge, and the checks of
            :mod:`torchshm.inference.checks` (posterior mass at a prior bound, noise model
            contradicted by the data). Empty for a clean run. Printed first by
            :meth:`summary` and ``str(post)``, saved with the posterior file.
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
    variational: VariationalPosterior | None = field(default=None, repr=False)
    n_chains: int = 1
    warnings: list[str] = field(default_factory=list)
    problem: Problem | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = int(np.shape(self.samples)[0]) if np.ndim(self.samples) else 0
        if isinstance(self.n_chains, bool) or int(self.n_chains) < 1 or n % int(self.n_chains):
            raise ValueError(
                f"Posterior: n_chains={self.n_chains!r} must be a positive integer that divides the "
                f"{n} samples (they are stored step-major, chain after chain within each step)"
            )

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
        """Mean, sd and 95 % equal-tailed interval of each parameter, from :attr:`samples`;
        :attr:`warnings` are its notes, the first lines of its printed form."""
        return summarize(self.names, self.samples, self.n_chains, tuple(self.warnings))

    def to_arviz(self) -> az.InferenceData:
        """The posterior as an ArviZ ``InferenceData``.

        Groups: ``posterior`` (one variable per parameter, dims ``chain, draw``: emcee's walkers
        are its chains, VBMC's draws one chain), ``sample_stats`` (e.g. emcee's ``lp``) and,
        when the problem is attached, ``observed_data`` in the layout of the netCDF file
        (:func:`~torchshm.inference.netcdf.observed_dataset`: ``y`` [µε] on ``load, x``, with a
        ``line`` variable for several sensor lines; on ``load, point`` with ``x`` on
        ``point, axis`` for `n x d` coordinates). The attributes hold the method, the evidence, the convergence flag and the
        warnings (a JSON list). Use it with ArviZ's
        own functions (``az.summary``, ``az.ess``, ``az.rhat``, ``az.plot_trace``).
        """
        import arviz as az

        posterior = {n: as_chains(self.samples[:, i], self.n_chains)
                     for i, n in enumerate(self.names)}
        stats = {k: as_chains(np.asarray(v), self.n_chains) for k, v in self.sample_stats.items()}
        meas = getattr(self.problem, "measurements", None)
        attrs = {"method": self.method, "converged": int(self.converged),
                 "n_model_evaluations": int(self.n_model_evaluations),
                 "warnings": json.dumps(list(self.warnings))}
        if self.log_evidence is not None:
            attrs["log_evidence"] = float(self.log_evidence)
        idata = az.from_dict(posterior=posterior, sample_stats=stats or None, attrs=attrs)
        if meas is not None:
            from torchshm.inference.netcdf import observed_dataset

            idata.add_groups(observed_data=observed_dataset(meas))
        idata.posterior.attrs.update(attrs)
        return idata

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
        return "\n".join([*self.warnings, head, self.summary().table()])
