"""Information gain from prior to posterior: KL divergence by Monte Carlo (paper, Eq. 19).

``D_KL(q || p) = E_q[log q(theta) - log p(theta)]`` with ``q`` the posterior's density
(``post.log_pdf``, the variational density for VBMC) and ``p`` the joint prior of the inferred
parameters (:class:`~torchshm.problem.JointPrior`, the one the problem used), estimated as the
mean over ``n`` draws of ``q``.
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
    """

    se: float
    n: int

    def __new__(cls, value: float, se: float, n: int) -> KLEstimate:
        obj = super().__new__(cls, value)
        obj.se, obj.n = float(se), int(n)
        return obj

    @property
    def value(self) -> float:
        """The estimate [nats]."""
        return float(self)

    def __str__(self) -> str:
        return f"{self.value:.3f} ± {self.se:.3f} nats (n = {self.n})"

    def __repr__(self) -> str:
        return f"KLEstimate(value={self.value!r}, se={self.se!r}, n={self.n})"


def kl_divergence(post: PosteriorLike, n: int = 10_000, seed: int = 0) -> KLEstimate:
    """KL divergence from the prior to the posterior, ``D_KL(posterior || prior)`` (Eq. 19).

    Args:
        post: a posterior with ``names``, ``sample(n, rng)``, ``log_pdf(theta)`` (normalised)
            and ``priors`` (name -> prior with ``log_prob``, or a number when fixed).
        n: number of Monte Carlo draws from the posterior.
        seed: seed of the draws.

    Returns:
        A :class:`KLEstimate` in nats with its Monte Carlo standard error.

    Raises:
        ValueError: when a draw has zero prior density (the posterior leaks out of the prior's
            support) or the densities are not finite.
    """
    names = list(post.names)
    theta = np.asarray(post.sample(n, np.random.default_rng(seed)), dtype=np.float64)
    log_q = np.asarray(post.log_pdf(theta), dtype=np.float64).reshape(-1)
    try:
        log_p = np.asarray(JointPrior(post.priors, names).log_prob(theta), dtype=np.float64)
    except ValueError as err:
        raise ValueError(f"kl_divergence: {err}") from None
    if not np.all(np.isfinite(log_p)):
        raise ValueError("kl_divergence: some posterior draws lie outside the prior's support")
    diff = log_q - log_p
    if not np.all(np.isfinite(diff)):
        raise ValueError("kl_divergence: the posterior density is not finite at some draws")
    return KLEstimate(float(diff.mean()), float(diff.std(ddof=1) / np.sqrt(diff.size)), int(diff.size))
