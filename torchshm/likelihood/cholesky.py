"""Batched Cholesky factorisation with a jitter that only ever touches the failed matrices.

Jitter policy: every matrix is first factorised as it is; a matrix that is positive definite to
working precision therefore gets exactly its own factor, never a perturbed one. Only the matrices
whose factorisation fails are retried, with ``jitter * I`` added, where ``jitter`` starts at
``1e-10`` times the mean of that matrix's diagonal and grows tenfold per retry up to ``1e-4``
times it. A matrix that still fails, or whose diagonal mean is not positive, is reported as
failed (the log-likelihood then gives -inf).
"""

from __future__ import annotations

import torch
from torch import Tensor

#: first jitter, relative to the mean of the diagonal of the failed matrix
JITTER_START = 1e-10
#: largest jitter tried, relative to the mean of the diagonal
JITTER_MAX = 1e-4


def cholesky_with_jitter(cov: Tensor) -> tuple[Tensor, Tensor]:
    """Lower Cholesky factors of a batch of symmetric matrices, with the jitter policy above.

    Args:
        cov: `... x n x n` symmetric matrices (may require grad).

    Returns:
        ``(chol, failed)``: `... x n x n` lower factors, differentiable w.r.t. ``cov``, and a
        bool `...` mask of the matrices that could not be factorised even with the largest
        jitter (their factor is the identity and must not be used).
    """
    chol, info = torch.linalg.cholesky_ex(cov)
    if not bool((info != 0).any()):
        return chol, info != 0
    jitter = _find_jitter(cov.detach(), info != 0)
    failed = ~torch.isfinite(jitter)
    eye = torch.eye(cov.shape[-1], dtype=cov.dtype, device=cov.device)
    safe = torch.where(failed[..., None, None], eye, cov)
    shift = torch.where(failed, 0.0, jitter)[..., None, None] * eye
    chol, _ = torch.linalg.cholesky_ex(safe + shift)
    return chol, failed


def _find_jitter(cov: Tensor, failed: Tensor) -> Tensor:
    """Per-matrix jitter `...`: 0 where ``cov`` factorises, inf where no tried jitter helps."""
    jitter = torch.zeros(failed.shape, dtype=cov.dtype, device=cov.device)
    scale = cov.diagonal(dim1=-2, dim2=-1).mean(-1)
    hopeless = failed & ~(scale > 0)  # a zero (or NaN) diagonal gives no scale for a jitter
    failed = failed & ~hopeless
    eye = torch.eye(cov.shape[-1], dtype=cov.dtype, device=cov.device)
    level = JITTER_START
    while level <= JITTER_MAX * (1 + 1e-9) and bool(failed.any()):
        idx = failed.nonzero(as_tuple=True)
        trial = level * scale[idx]
        _, info = torch.linalg.cholesky_ex(cov[idx] + trial[:, None, None] * eye)
        jitter[idx] = trial
        failed[idx] = info != 0
        level *= 10.0
    jitter[failed | hopeless] = torch.inf
    return jitter
