"""Does the variational posterior explain the log joint where VBMC itself evaluated it?

PyVBMC's convergence test compares successive iterations of its own fit: a variational posterior
that sits in one mode while the GP's training set holds points of a better one, or that is too
narrow along a ridge the training set explored, can pass it. Every point VBMC evaluated carries
the true log joint ``y`` at no extra model run; where the posterior is right,
``y - log q(x)`` is the log evidence, up to the ELBO's small gap. So ``y - ELBO`` estimates the
posterior's log density at each evaluated point. A point where that density is as high as the
variational posterior's own typical density (above the 5 % quantile of ``log q`` at its draws)
while ``q`` there is many nats lower is a region of the posterior's bulk that ``q`` underweights
by that factor: a mode it missed, or a width it cut. Points in the far tails, where a Gaussian
mixture is lighter than the posterior without that mattering, do not count.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np


class Excess(NamedTuple):
    """The log joint against the variational posterior at the evaluated points of the bulk."""

    #: the largest ``y - log q(x) - ELBO`` [nats] over them (0 without any)
    largest: float
    #: how many there were, and how many exceeded :data:`TOLERANCE`
    n_bulk: int
    n_over: int
    #: the point of the largest excess `D` (empty without any)
    where: np.ndarray


#: nats by which the posterior may underweight an evaluated point of its bulk (a factor of 20)
TOLERANCE = 3.0
#: quantile of ``log q`` at the posterior's own draws above which a density counts as the bulk's
TYPICAL = 0.05


def evaluated_excess(x: np.ndarray, y: np.ndarray, log_q: np.ndarray, elbo: float,
                     log_q_draws: np.ndarray) -> Excess:
    """Compare evaluated log joints ``y`` `M` at points ``x`` `M x D` with the variational log
    density ``log_q`` `M` there, the ``elbo`` and ``log_q_draws`` `S`, ``log q`` at draws of
    ``q`` itself (module docstring)."""
    x, y, log_q = np.atleast_2d(x), np.asarray(y, dtype=np.float64), np.asarray(log_q, dtype=np.float64)
    draws = np.asarray(log_q_draws, dtype=np.float64)
    draws = draws[np.isfinite(draws)]
    ok = np.isfinite(y)
    if not ok.any() or not np.isfinite(elbo) or not draws.size:
        return Excess(0.0, 0, 0, np.zeros(0))
    bulk = ok & (y - elbo >= np.quantile(draws, TYPICAL))
    if not bulk.any():
        return Excess(0.0, 0, 0, np.zeros(0))
    excess = np.where(np.isfinite(log_q[bulk]), y[bulk] - log_q[bulk] - elbo, np.inf)
    k = int(np.argmax(excess))
    return Excess(float(excess[k]), int(bulk.sum()), int((excess > TOLERANCE).sum()), x[bulk][k])


def against_evaluations(vp: Any, x: np.ndarray, y: np.ndarray, samples: np.ndarray,
                        elbo: float) -> Excess:
    """:func:`evaluated_excess` of PyVBMC's posterior ``vp`` at the evaluated points ``x``
    `M x D` with log joints ``y`` `M`, its typical density from ``samples`` `S x D` of it."""
    if not np.size(x):
        return Excess(0.0, 0, 0, np.zeros(0))
    log_q = np.asarray(vp.pdf(x, log_flag=True), dtype=np.float64).reshape(-1)
    own = np.asarray(vp.pdf(samples[:2000], log_flag=True), dtype=np.float64).reshape(-1)
    return evaluated_excess(x, y, log_q, elbo, own)


def misfit_line(diagnostics: dict) -> str:
    """The ``VBMC MISFIT`` warning line of a VBMC posterior that underweights evaluated points
    of its bulk (``diagnostics`` of the posterior)."""
    return (f"VBMC MISFIT: the variational posterior does not explain the log joint VBMC "
            f"evaluated: at {diagnostics['evaluated_over']} of the {diagnostics['evaluated_bulk']} "
            f"evaluated points where the posterior's density is that of its bulk, the variational "
            f"density is more than {TOLERANCE:g} nats lower, up to "
            f"{diagnostics['evaluated_excess']:.3g} nats: it may miss part of the posterior (a "
            f"mode, or its width along a ridge) and its log evidence may be low, whatever its "
            f"convergence test said. Fix: method='emulator', or rerun VBMC on the same store with "
            f"another seed and a larger max_fun_evals (finished model runs are reused)")


__all__ = ["Excess", "TOLERANCE", "TYPICAL", "against_evaluations", "evaluated_excess", "misfit_line"]
