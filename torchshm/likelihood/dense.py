"""The dense Gaussian log density with its gradient in closed form.

For one covariance ``Σ`` (`n x n`) and residual ``r`` (`n`)::

    log p = -½ (rᵀ Σ⁻¹ r + log|Σ| + n log 2π)
    ∂ log p / ∂r = -α,      ∂ log p / ∂Σ = ½ (α αᵀ - Σ⁻¹),      α = Σ⁻¹ r

Autograd through ``torch.linalg.cholesky_ex`` and ``solve_triangular`` gets the same gradient
but spends about three times the forward pass on it (its Cholesky backward solves with the
factor on `n x n` right-hand sides twice). Here the backward pass is one ``cholesky_inverse``
and outer products, from the factor kept by the forward pass: for 64 vectors, three load
cases and 351 points, value and gradient with respect to the strains took 1.0 s of CPU against
3.8 s through autograd (one thread; ``docs/benchmarks.md``). The jitter policy is
:func:`~torchshm.likelihood.cholesky.cholesky_with_jitter`'s; the gradient is that of the
jittered matrix, as autograd's would be. The second derivative is not provided.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor
from torch.autograd.function import once_differentiable

from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.constants import LOG_2PI


def dense_log_density(cov: Tensor, resid: Tensor) -> Tensor:
    """Gaussian log densities `B` of residuals under dense covariances, summed over load cases.

    Args:
        cov: `B x L' x n x n` symmetric covariances [µε²], one per load case (``L' = L``) or one
            shared by all ``L`` load cases (``L' = 1``); may require grad.
        resid: `B x L x n` residuals ``y - eta`` [µε]; may require grad.

    Returns:
        `B` log densities (float64); -inf for a vector one of whose covariances cannot be
        factorised even with the largest jitter (its gradient is zero).
    """
    if cov.shape[1] not in (1, resid.shape[1]):
        raise ValueError(f"dense_log_density: {cov.shape[1]} covariances for {resid.shape[1]} "
                         "load cases (one per load case, or one for all)")
    return _DenseGaussian.apply(cov, resid)


class _DenseGaussian(torch.autograd.Function):
    """Forward: Cholesky (with jitter), one triangular solve, the log determinant. Backward:
    ``α`` from the kept factor, ``Σ⁻¹`` only where the covariance needs a gradient."""

    @staticmethod
    def forward(ctx: Any, cov: Tensor, resid: Tensor) -> Tensor:
        n_loads, n = resid.shape[1], resid.shape[2]
        chol, failed = cholesky_with_jitter(cov)
        z = torch.linalg.solve_triangular(chol, resid.unsqueeze(-1), upper=False)
        log_det = 2.0 * chol.diagonal(dim1=-2, dim2=-1).log().sum(-1)  # B x L'
        log_det = log_det.sum(-1) * (n_loads / cov.shape[1])
        value = -0.5 * (z.square().sum((-1, -2, -3)) + log_det + n_loads * n * LOG_2PI)
        bad = failed.any(-1)
        ctx.save_for_backward(chol, z, bad)
        return torch.where(bad, -torch.inf, value)

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad: Tensor) -> tuple[Tensor | None, Tensor | None]:
        chol, z, bad = ctx.saved_tensors
        weight = torch.where(bad, 0.0, grad)  # B; a failed vector passes no gradient
        alpha = torch.linalg.solve_triangular(chol.mT, z, upper=True).squeeze(-1)  # B x L x n
        alpha = torch.where(bad[:, None, None], 0.0, alpha)
        grad_resid = -weight[:, None, None] * alpha if ctx.needs_input_grad[1] else None
        grad_cov = None
        if ctx.needs_input_grad[0]:
            n_loads, shared = alpha.shape[1], chol.shape[1]
            if shared == n_loads:
                outer = alpha.unsqueeze(-1) * alpha.unsqueeze(-2)  # B x L x n x n
            else:  # one covariance for every load case: Σ_l α_l α_lᵀ
                outer = (alpha.mT @ alpha).unsqueeze(1)
            inverse = torch.cholesky_inverse(chol)
            grad_cov = 0.5 * weight[:, None, None, None] * (outer - (n_loads / shared) * inverse)
        return grad_cov, grad_resid
