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


def physical_columns(problem: Any, theta: np.ndarray) -> np.ndarray:
    """Full physical vectors θp `B x P` (fixed values filled in) of rows ``theta`` `B x D`
    (the problem's :class:`~torchshm.problem.ParameterSplit`)."""
    return problem.split.physical(np.atleast_2d(np.asarray(theta, dtype=np.float64))).numpy()


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

    def parts(self, theta: np.ndarray) -> tuple[Tensor, Tensor, Tensor, Tensor | None]:
        """Emulator mean and variance `B x L x n`, σa `B` and l `B` (None for a kernel without
        length) of rows `B x D`, split by ``problem.split`` (fixed values filled in)."""
        rows = torch.as_tensor(np.atleast_2d(theta), dtype=torch.float64)
        theta_p, sa, ell = self.problem.split.split(rows)
        mean, var = self.emulator.predict(theta_p)
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
        levels = noise_levels(p.sigma_e, var.reshape(var.shape[0], -1).amax(-1).numpy())
        if p.kernel.name == "independent":  # covariance (σa² + σe²) I + σm² diag(m²): the
            extra = torch.as_tensor(levels**2 - p.sigma_e**2)  # raised noise folds into σa
            values = log_likelihood(self.y, mean, self.x, p.kernel, (sa.square() + extra).sqrt(),
                                    None, p.sigma_m, p.sigma_e).numpy()
            values[np.isnan(values)] = -np.inf
            return values
        values = np.empty(theta.shape[0])
        for level in np.unique(levels):  # one batched call per noise level
            rows = torch.as_tensor(np.flatnonzero(levels == level))
            values[rows.numpy()] = log_likelihood(
                self.y, mean[rows], self.x, p.kernel, sa[rows],
                None if ell is None else ell[rows], p.sigma_m, float(level),
            ).numpy()
        values[np.isnan(values)] = -np.inf
        return values

    def emulator_share(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How much the emulator's uncertainty matters at rows ``theta`` `B x D`.

        Returns:
            ``(share, sd_loglik)``, both `B`: the emulator's share of the predictive variance,
            ``v_j / (v_j + s_j²)`` averaged over the measured outputs, with ``s_j²`` the
            diagonal of the Eq. (21) covariance (``σm² m_j² + k(x_j, x_j) + σe²``, the kernel's
            own diagonal); and the standard deviation [nats] of the log-likelihood that the
            emulator error causes, to first order ``sqrt(Σ_j v_j / s_j²)``.
        """
        p = self.problem
        mean, var, sa, _ = self.parts(theta)
        kernel_diag = p.kernel.diag(self.x, sigma_a=sa)[:, None, :]  # B x 1 x n
        data = p.sigma_m**2 * mean.square() + kernel_diag + p.sigma_e**2
        share = (var / (var + data)).mean((-1, -2)).numpy()
        sd = (var / data).sum((-1, -2)).sqrt().numpy()
        return share, sd
