"""What a posterior is, for the functions that read one (predictive checks, Bayes factors, KL).

:class:`~torchshm.inference.Posterior` follows this protocol; so can a user's own posterior
(e.g. a Gaussian approximation) to be used with :func:`~torchshm.predictive.posterior_predictive`,
:func:`~torchshm.predictive.bayes_factors` and :func:`~torchshm.predictive.kl_divergence`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from torchshm.problem import Problem


@runtime_checkable
class PosteriorLike(Protocol):
    """Structural protocol of a posterior over the `D` inferred parameters.

    Attributes:
        names: the `D` inferred parameter names, in column order.
        priors: name -> prior (with ``log_prob``) or a number (a fixed parameter).
        problem: the :class:`~torchshm.problem.Problem` it came from, or ``None`` (e.g. loaded
            from a file).
        log_evidence: log marginal likelihood estimate [nats] (the ELBO for VBMC), or ``None``.
    """

    names: list[str]
    priors: Mapping[str, Any]
    problem: Problem | None
    log_evidence: float | None

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """`n x D` draws from the posterior."""
        ...

    def log_pdf(self, theta: np.ndarray) -> np.ndarray:
        """Normalised log density `...` at ``theta`` (`... x D`)."""
        ...
