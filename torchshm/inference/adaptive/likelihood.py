"""The log joint on the field emulator, carrying the emulator's own uncertainty.

For a parameter vector θ = (θp, σa, l) the emulator gives the strains' mean m(θp) and variance
v_j(θp) at every measured output j. The likelihood is Eq. (21) with ``eta = m`` and the noise
variance raised from σe² to ``σe² + max_j v_j(θp)``: a covariance at least as large as Eq. (21)
plus ``diag(v)`` (the exact marginal over a Gaussian emulator error when σm = 0), so the
posterior is never more confident than the emulator allows. Once the emulator is accurate
where the posterior lies (the stop rule asks for it), the added variance is negligible and the
likelihood is Eq. (21) itself. The likelihood is computed by the public
:func:`torchshm.log_likelihood`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from torch import Tensor

from torchshm.inference.adaptive.field import FieldEmulator
from torchshm.likelihood import log_likelihood

#: parameters of the discrepancy (everything else in ``problem.names`` is physical)
STATISTICAL = ("sigma_a", "length")


def physical_columns(problem: Any, theta: np.ndarray) -> np.ndarray:
    """Full physical vectors θp `B x P` (fixed values filled in) of rows ``theta`` `B x D`."""
    theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
    cols = []
    for name in problem.physical_names:
        if name in problem.names:
            cols.append(theta[:, problem.names.index(name)])
        else:
            cols.append(np.full(theta.shape[0], float(problem.priors[name])))
    return np.column_stack(cols)


def statistical_column(problem: Any, theta: np.ndarray, name: str) -> np.ndarray:
    """Values `B` of ``sigma_a`` or ``length`` (inferred or fixed; 0 when absent)."""
    if name in problem.names:
        return theta[:, problem.names.index(name)]
    return np.full(theta.shape[0], float(problem.priors.get(name, 0.0)))


def noise_levels(sigma_e: float, extra: np.ndarray, step: float = 0.01) -> np.ndarray:
    """Noise sd [µε] of each row: ``sqrt(σe² + extra)`` rounded up to a grid of relative
    ``step`` (so rows share a few levels and are evaluated in batches; rounding up keeps the
    covariance at least as large)."""
    exact = np.sqrt(sigma_e**2 + np.clip(extra, 0.0, None))
    if sigma_e <= 0:
        return exact
    k = np.ceil(np.log(exact / sigma_e) / np.log1p(step) - 1e-9).clip(0)
    return sigma_e * np.exp(k * np.log1p(step))


class EmulatedLogJoint:
    """Log prior plus the emulated log-likelihood of ``problem``; no model run.

    Args:
        problem: a :class:`~torchshm.Problem` (its priors, kernel, σm, σe, data).
        emulator: the :class:`FieldEmulator` of the measured strains.
    """

    def __init__(self, problem: Any, emulator: FieldEmulator) -> None:
        self.problem, self.emulator = problem, emulator
        m = problem.measurements
        self.y = torch.as_tensor(np.asarray(m.y, dtype=np.float64))
        self.x = torch.as_tensor(np.asarray(m.x, dtype=np.float64))

    def parts(self, theta: np.ndarray) -> tuple[Tensor, Tensor, np.ndarray, np.ndarray]:
        """Emulator mean and variance `B x L x n`, σa `B` and l `B` of rows `B x D`."""
        theta = np.atleast_2d(theta)
        mean, var = self.emulator.predict(torch.as_tensor(physical_columns(self.problem, theta)))
        sa = statistical_column(self.problem, theta, "sigma_a")
        ell = statistical_column(self.problem, theta, "length")
        return mean, var, sa, ell

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        """Log joint `B` of rows ``theta`` `B x D`; -inf outside the prior support."""
        theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
        out = np.asarray(self.problem.log_prior(theta), dtype=np.float64).reshape(-1)
        ok = np.isfinite(out)
        if ok.any():
            out[ok] += self.log_likelihood(theta[ok])
        out[~np.isfinite(out)] = -np.inf
        return out

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Emulated log-likelihood `B` of rows `B x D` inside the support."""
        p = self.problem
        mean, var, sa, ell = self.parts(theta)
        has_length = p.kernel.has_length
        levels = noise_levels(p.sigma_e, var.reshape(var.shape[0], -1).amax(-1).numpy())
        values = np.empty(theta.shape[0])
        for level in np.unique(levels):  # one batched call per noise level
            rows = np.flatnonzero(levels == level)
            values[rows] = log_likelihood(
                self.y, mean[rows], self.x, p.kernel, torch.as_tensor(sa[rows]),
                torch.as_tensor(ell[rows]) if has_length else None, p.sigma_m, float(level),
            ).numpy()
        values[np.isnan(values)] = -np.inf
        return values

    def emulator_share(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How much the emulator's uncertainty matters at rows ``theta`` `B x D`.

        Returns:
            ``(share, sd_loglik)``, both `B`: the emulator's share of the predictive variance,
            ``v_j / (v_j + σm² m_j² + σa² + σe²)`` averaged over the measured outputs; and the
            standard deviation [nats] of the log-likelihood that the emulator error causes,
            to first order ``sqrt(Σ_j v_j / s_j²)`` with ``s_j²`` the data variance of output j.
        """
        p = self.problem
        mean, var, sa, _ = self.parts(theta)
        sa2 = torch.as_tensor(sa**2)[:, None, None]
        data = p.sigma_m**2 * mean.square() + sa2 + p.sigma_e**2
        share = (var / (var + data)).mean((-1, -2)).numpy()
        sd = (var / data).sum((-1, -2)).sqrt().numpy()
        return share, sd
