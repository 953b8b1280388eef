"""The log joint on the field emulator, and the log-likelihood error its uncertainty causes.

For a parameter vector θ = (θp, σa, l[, σm, σe]) the emulator gives the strains' mean m(θp) and
variance v_j(θp) at every measured reading j. The posterior's likelihood is Eq. (21) with
``eta = m`` (plug-in). The variance is not added to each reading's variance: that would be the
exact marginal over the emulator's error only if the error were independent from reading to
reading, while it is a smooth field that the discrepancy absorbs; added per reading it penalised
every region where the emulator is uncertain (about ``½ Σ_j [log(1 + v_j/s_j²) - v_j/(s_j² + v_j)]``
nats) and cut the posterior there (``docs/inference.md`` step 3). The variance, times the
calibration ``c >= 1`` (how much larger the errors at new runs were than predicted,
:mod:`.validation`), gives instead the log-likelihood sd the emulator causes
(:meth:`EmulatedLogJoint.value_and_sd`, :meth:`EmulatedLogJoint.error_variance`), which the stop
rule, the exploration and the batch rule use.

The data are seen only through the problem's one view of them: ``problem.at_measured`` (the
measured load cases and positions, exact or interpolated), ``problem.blocks`` (one independent
Gaussian per sensor line and set of valid readings: several fibres, dropouts, 2-D fields) and
``problem.noise_of`` (fixed or inferred σm, σe); the density is
:func:`torchshm.likelihood.blocks.blocks_log_likelihood`, the one the problem itself uses.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from torchshm.inference.adaptive.field import FieldEmulator
from torchshm.likelihood.blocks import blocks_log_likelihood
from torchshm.likelihood.statespace import BATCH_STATE_SPACE_FROM

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger(__name__)

#: 1-D blocks of a Markov kernel from this many readings use the exact O(n) state space
STATE_SPACE_FROM = BATCH_STATE_SPACE_FROM


def physical_columns(problem: Problem, theta: np.ndarray) -> np.ndarray:
    """Full physical vectors θp `B x P` (fixed values filled in) of rows ``theta`` `B x D`
    (the problem's :class:`~torchshm.problem.ParameterSplit`)."""
    return problem.split.physical(np.atleast_2d(np.asarray(theta, dtype=np.float64))).numpy()


class EmulatedLogJoint:
    """Log prior plus the emulated log-likelihood of ``problem``; no model run.

    Args:
        problem: a :class:`~torchshm.Problem` (its priors, kernel, noise levels, data view).
        emulator: the :class:`FieldEmulator` of the strains at the measured readings.
        inflation: factor ``c >= 1`` on the emulator's variance (its calibration).
    """

    def __init__(self, problem: Problem, emulator: FieldEmulator, inflation: float = 1.0) -> None:
        self.problem, self.emulator = problem, emulator
        self.inflation = float(max(1.0, inflation))
        self.y = problem.y
        self.valid = _valid_mask(problem)  # L x n readings that enter some block

    def parts(self, theta: np.ndarray) -> tuple[Tensor, Tensor, Tensor]:
        """Emulator mean and inflated variance `B x L x n` [µε, µε²] and the rows `B x D`."""
        rows = torch.as_tensor(np.atleast_2d(theta), dtype=torch.float64)
        mean, var = self.emulator.predict(self.problem.split.physical(rows))
        return mean, var * self.inflation, rows

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
        """Emulated log-likelihood `B` of rows `B x D` inside the support: Eq. (21) at the
        emulator's mean (module docstring); the emulator's variance is not computed."""
        rows = torch.as_tensor(np.atleast_2d(theta), dtype=torch.float64)
        return self.at(self.emulator.predict_mean(self.problem.split.physical(rows)), None, rows)

    def at(self, mean: Tensor, var: Tensor | None, rows: Tensor) -> np.ndarray:
        """Eq. (21) log-likelihood `B` of predictions ``mean`` `B x L x n` with the extra
        variance ``var`` (or None) for parameter rows `B x D`."""
        p = self.problem
        sigma_a, length = p.split.discrepancy(rows)
        sigma_m, method, _, sigma_e = p.noise_of(rows)
        with torch.no_grad():
            values = blocks_log_likelihood(p.y, mean, p.blocks, p.kernel, sigma_a, length, sigma_m,
                                           method, var, sigma_e, STATE_SPACE_FROM).numpy()
        values[np.isnan(values)] = -np.inf
        return values

    def at_error(self, mean: Tensor, var: Tensor, rows: Tensor, z: Tensor) -> np.ndarray:
        """Eq. (21) log-likelihood `B` at the emulator's mean `B x L x n` plus an error field:
        ``sqrt(var_j) (E z)_j`` at reading `j`, ``E`` the runs' field shapes
        (:attr:`FieldEmulator.error_basis`, `m x N`, unit rows) and ``z`` `B x N` standard
        draws of its latent GP (the error model of :meth:`error_variance`, not to first order)."""
        delta = var.sqrt().flatten(1) * (z @ self.emulator.error_basis.mT)
        return self.at(mean + delta.reshape(mean.shape), None, rows)

    def value_and_sd(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log joint `B` of rows `B x D` (-inf outside the support) and the sd [nats] of the
        log-likelihood that the emulator error causes there (:meth:`error_variance`)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
        out = np.asarray(self.problem.log_prior(theta), dtype=np.float64).reshape(-1)
        sd = np.zeros_like(out)
        ok = np.isfinite(out)
        if ok.any():
            mean, var, rows = self.parts(theta[ok])
            values, grad = self.gradient(mean, var, rows)
            out[ok] += values
            sd[ok] = self.error_variance(mean, var, rows, grad).sqrt().numpy()
        out[~np.isfinite(out)] = -np.inf
        return out, sd

    def error_variance(self, mean: Tensor, var: Tensor, rows: Tensor, grad: Tensor) -> Tensor:
        """Variance `B` [nats²] of the log-likelihood that the emulator error causes at rows
        `B x D`, from the emulator's mean and variance `B x L x n` there and ``grad = ∂ℓ/∂η``.

        The delta method ``‖Bᵀ(√v ⊙ g)‖² + ½ Σ_j v_j² / s_j⁴`` with the error correlated across
        readings as the runs' fields are (:attr:`FieldEmulator.error_basis` `B`), ``g`` the
        gradient of the problem's own Eq. (21) log-likelihood (the discrepancy's covariance
        included) and ``s_j²`` the diagonal of its covariance. Measured against the true model
        on the suite's and held-out cases (``scripts/bench_emulator_error.py``), this is the
        form closest to calibrated far from the posterior (rms of error / sd 1.42 in the
        median, worst 5.2); with the outputs' errors independent, as the emulator itself has
        them, 4.7 (worst 27); with the diagonal of the covariance alone, 1.56 (worst 16).
        """
        data = self.data_variance(mean, rows)
        valid = self.valid.to(var.dtype)
        weighted = (var.sqrt() * torch.nan_to_num(grad) * valid).reshape(var.shape[0], -1)
        first = (weighted @ self.emulator.error_basis).square().sum(-1)
        return first + 0.5 * (var.square() / data.square() * valid).sum((-1, -2))

    def gradient(self, mean: Tensor, var: Tensor, rows: Tensor) -> tuple[np.ndarray, Tensor]:
        """Eq. (21) log-likelihood `B` of predictions ``mean`` `B x L x n` with the extra
        variance ``var`` for rows `B x D` (as :meth:`at`), and its gradient ``∂ℓ/∂η`` at
        ``mean``, `B x L x n` (autograd; 0 for rows whose value is not finite)."""
        p = self.problem
        sigma_a, length = p.split.discrepancy(rows)
        sigma_m, method, _, sigma_e = p.noise_of(rows)
        eta = mean.detach().clone().requires_grad_(True)
        with torch.enable_grad():
            values = blocks_log_likelihood(p.y, eta, p.blocks, p.kernel, sigma_a, length, sigma_m,
                                           method, var, sigma_e, STATE_SPACE_FROM)
            total = torch.where(torch.isfinite(values), values, 0.0).sum()
            grad = (torch.autograd.grad(total, eta, allow_unused=True)[0]
                    if total.requires_grad else None)  # a path that returned constants
        out = values.detach().numpy().copy()
        out[~np.isfinite(out)] = -np.inf
        if grad is None and np.isfinite(out).any():
            _warn_no_gradient(p.kernel.name)
        return out, torch.zeros_like(mean) if grad is None else grad

    def emulator_share(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How much the emulator's uncertainty matters at rows ``theta`` `B x D`.

        Returns:
            ``(share, sd_loglik)``, both `B`: the emulator's share of the predictive variance,
            ``v_j / (v_j + s_j²)`` averaged over the valid readings, with ``s_j²`` the diagonal
            of the Eq. (21) covariance (``σm² m_j² + k(x_j, x_j) + σe²``); and the standard
            deviation [nats] of the log-likelihood that the emulator error causes, to first
            order ``sqrt(Σ_j v_j / s_j²)``.
        """
        mean, var, rows = self.parts(theta)
        data = self.data_variance(mean, rows)
        valid = self.valid.to(var.dtype)
        share = ((var / (var + data)) * valid).sum((-1, -2)) / valid.sum()
        sd = ((var / data) * valid).sum((-1, -2)).sqrt()
        return share.numpy(), sd.numpy()

    def data_variance(self, mean: Tensor, rows: Tensor) -> Tensor:
        """Diagonal of the Eq. (21) covariance `B x L x n` [µε²] (σm² m² + k(x, x) + σe²),
        block by block; 1 at readings outside every block."""
        p = self.problem
        sigma_a, _ = p.split.discrepancy(rows)
        sigma_m, _, _, scale = p.noise_of(rows)
        sm = sigma_m.reshape(-1, 1, 1) if isinstance(sigma_m, Tensor) else sigma_m
        out = torch.ones_like(mean)
        for block in p.blocks:
            idx = (block.loads[:, None], block.points[None, :])
            noise = block.sigma_e if scale is None else block.sigma_e * scale.reshape(-1, 1, 1)
            points = block.x if block.x.ndim == 1 else block.x[:, 0]
            kern = p.kernel.diag(points, sigma_a=sigma_a[:, block.group])[:, None, :]
            m = mean[:, idx[0], idx[1]]
            out[:, idx[0], idx[1]] = (sm * m).square() + kern + torch.as_tensor(noise).square()
        return out


def _warn_no_gradient(kernel: str) -> None:
    """Say once per process that the likelihood's form gave no gradient in the strains."""
    global _WARNED_NO_GRADIENT
    if _WARNED_NO_GRADIENT:
        return
    _WARNED_NO_GRADIENT = True
    logger.warning(
        "emulator: the likelihood form of kernel %r here has no gradient in the strains (kernel "
        "'upscaled' with an element side far below the points' pitch takes the sparse LU), so the "
        "log-likelihood sd that the emulator's error causes is its second-order term alone and "
        "understates it: the exploration and the stop rule may trust the emulator too early; "
        "prefer method='vbmc' here, or points no sparser than the elements", kernel)


_WARNED_NO_GRADIENT = False


def _valid_mask(problem: Problem) -> Tensor:
    """`L x n` booleans: the readings some block of ``problem`` uses."""
    valid = torch.zeros(problem.y.shape, dtype=torch.bool)
    for block in problem.blocks:
        valid[block.loads[:, None], block.points[None, :]] = True
    return valid
