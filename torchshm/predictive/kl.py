"""Information gain from prior to posterior: KL divergence by Monte Carlo (paper, Eq. 19).

``D_KL(q || p) = E_q[log q(theta) - log p(theta)]`` with ``q`` the posterior's density and
``p`` the joint prior of the inferred parameters (:class:`~torchshm.problem.JointPrior`, the
one the problem used). Two sources of ``log q``:

- ``"posterior density"``: the posterior has one (``post.log_pdf``: VBMC's variational
  posterior, the emulator method's fitted mixture); the estimate is the mean over ``n`` draws
  of ``q``, with its Monte Carlo standard error;
- ``"fitted mixture"``: the posterior has samples only (emcee). A Gaussian mixture with full
  covariances is fitted to half of the samples in PyVBMC's unbounded coordinates (the emulator
  method's importance proposal, :func:`~torchshm.inference.adaptive.mixture.fit_mixture`) and ``log q`` is evaluated on the
  other, held-out half; the halves are the first and second half of the chain, and the two
  ways round are averaged. A held-out density underestimates the KL by ``KL(q || q_fit)``; the
  same density evaluated on its own half overestimates it (it has seen those samples). The
  gap between the two is reported as :attr:`KLEstimate.density_error`: the density's share
  of the error, beside the Monte Carlo one (:attr:`KLEstimate.se`, from 20 batch means along
  the chain, so that its autocorrelation counts).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from torchshm.problem.prior import JointPrior

if TYPE_CHECKING:
    from torchshm.inference.protocol import PosteriorLike


class KLEstimate(float):
    """A Monte Carlo estimate of the KL divergence: a float [nats] that also carries its error.

    Attributes:
        value: the estimate [nats] (the float itself).
        se: its Monte Carlo standard error [nats].
        n: number of draws.
        source: where ``log q`` came from: ``"posterior density"`` or ``"fitted mixture"``.
        density_error: for a fitted mixture, its in-sample minus held-out estimate [nats]
            (how much the density's fit moves the value); ``None`` for a posterior density.
    """

    se: float
    n: int
    source: str
    density_error: float | None

    def __new__(cls, value: float, se: float, n: int, source: str = "posterior density",
                density_error: float | None = None) -> KLEstimate:
        obj = super().__new__(cls, value)
        obj.se, obj.n, obj.source = float(se), int(n), str(source)
        obj.density_error = None if density_error is None else float(density_error)
        return obj

    @property
    def value(self) -> float:
        """The estimate [nats]."""
        return float(self)

    def __str__(self) -> str:
        if self.density_error is None:
            return f"{self.value:.3f} ± {self.se:.3f} nats (n = {self.n})"
        return (f"{self.value:.3f} ± {self.se:.3f} nats (n = {self.n}, {self.source}; "
                f"density error {self.density_error:.3f} nats)")

    def __repr__(self) -> str:
        extra = "" if self.density_error is None else \
            f", source={self.source!r}, density_error={self.density_error!r}"
        return f"KLEstimate(value={self.value!r}, se={self.se!r}, n={self.n}{extra})"


def kl_divergence(post: PosteriorLike, n: int = 10_000, seed: int = 0) -> KLEstimate:
    """KL divergence from the prior to the posterior, ``D_KL(posterior || prior)`` (Eq. 19).

    Args:
        post: a posterior with ``names``, ``sample(n, rng)``, ``priors`` (name -> prior with
            ``log_prob``, or a number when fixed) and either ``log_pdf(theta)`` (normalised) or
            ``samples`` (`S x D`, chain order) for a fitted mixture (module docstring).
        n: number of Monte Carlo draws from a posterior density (a fitted mixture uses the
            samples, at most ``n`` of them, evenly thinned).
        seed: seed of the draws and of the mixture fit.

    Returns:
        A :class:`KLEstimate` in nats with its Monte Carlo standard error and its source.

    Raises:
        ValueError: when a draw has zero prior density (the posterior leaks out of the prior's
            support), the densities are not finite, or a posterior without density has fewer
            than ``MIN_SAMPLES_PER_DIM`` samples per parameter to fit one.
    """
    names = list(post.names)
    theta = np.asarray(post.sample(n, np.random.default_rng(seed)), dtype=np.float64)
    try:
        log_q = np.asarray(post.log_pdf(theta), dtype=np.float64).reshape(-1)
    except NotImplementedError:
        return _fitted(post, names, n, seed)
    diff = log_q - _log_prior(post, names, theta)
    if not np.all(np.isfinite(diff)):
        raise ValueError("kl_divergence: the posterior density is not finite at some draws")
    return KLEstimate(float(diff.mean()), float(diff.std(ddof=1) / np.sqrt(diff.size)), int(diff.size))


#: fewest posterior samples per parameter from which a density is fitted
MIN_SAMPLES_PER_DIM = 50
#: batches along the chain for the Monte Carlo error of a fitted-mixture estimate
N_BATCHES = 20


def _log_prior(post: PosteriorLike, names: list[str], theta: np.ndarray) -> np.ndarray:
    try:
        log_p = np.asarray(JointPrior(post.priors, names).log_prob(theta), dtype=np.float64)
    except ValueError as err:
        raise ValueError(f"kl_divergence: {err}") from None
    if not np.all(np.isfinite(log_p)):
        raise ValueError("kl_divergence: some posterior draws lie outside the prior's support")
    return log_p


def _fitted(post: PosteriorLike, names: list[str], n: int, seed: int) -> KLEstimate:
    """The fitted-mixture estimate (module docstring) from ``post.samples``."""
    from torchshm.inference.adaptive.mixture import fit_mixture
    from torchshm.inference.adaptive.sampling import transformer

    samples = np.asarray(getattr(post, "samples", np.zeros((0, len(names)))), dtype=np.float64)
    if samples.shape[0] < 2 * MIN_SAMPLES_PER_DIM * len(names):
        raise ValueError(
            f"kl_divergence: a {getattr(post, 'method', '')!r} posterior has no density and "
            f"{samples.shape[0]} samples, too few to fit one ({2 * MIN_SAMPLES_PER_DIM * len(names)} needed)"
        )
    samples = samples[:: max(1, samples.shape[0] // max(int(n), 2 * MIN_SAMPLES_PER_DIM * len(names)))]
    prior = JointPrior(post.priors, names)
    hard, plausible = prior.hard_bounds, prior.plausible_bounds
    halves = np.array_split(samples, 2)
    log_p = [_log_prior(post, names, h) for h in halves]
    held, own = [], []
    for i, half in enumerate(halves):
        mix = fit_mixture(half, transformer(np.asarray(hard), np.asarray(plausible)), seed)
        other = halves[1 - i]
        held.append(mix.log_pdf(other) - log_p[1 - i])
        own.append(mix.log_pdf(half) - log_p[i])
    diff = np.concatenate(held[::-1])  # chain order: first half, then second half
    if not np.all(np.isfinite(diff)):
        raise ValueError("kl_divergence: the fitted density is not finite at some samples")
    batches = np.array([b.mean() for b in np.array_split(diff, N_BATCHES)])
    value = float(diff.mean())
    return KLEstimate(value, float(batches.std(ddof=1) / np.sqrt(N_BATCHES)), int(diff.size),
                      "fitted mixture", float(np.concatenate(own).mean()) - value)
