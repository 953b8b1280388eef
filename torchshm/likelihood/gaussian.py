"""The likelihood of Eq. (21): a Gaussian per load case with a correlated discrepancy.

For load case ``l`` with model prediction ``eta_l`` (`n`) at positions ``x``::

    y_l ~ N(eta_l, sigma_m**2 diag(eta_l)**2 + K + sigma_e**2 I)

where ``K`` is the discrepancy kernel matrix, shared by all load cases of one parameter vector.
Load cases are independent (block-diagonal covariance), so the log-likelihood is the sum of `L`
`n`-dimensional Gaussian log densities; it is never formed as one `L n x L n` matrix.
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from torchshm.kernels import Kernel, get_kernel
from torchshm.kernels.base import as_float64
from torchshm.likelihood import hilbert
from torchshm.likelihood.marginal import Eq21, choose_method

#: largest covariance buffer [bytes] factorised at once (at least one parameter vector per
#: chunk): bigger batches are split, which bounds memory and avoids the page faults and cache
#: misses of very large temporary buffers
CHUNK_BYTES = 2**22
#: largest batch of residuals [bytes] handled at once by the state-space form
STATE_SPACE_CHUNK_BYTES = 2**24


def log_likelihood(
    y: object,
    eta: object,
    x: object,
    kernel: str | Kernel,
    sigma_a: object,
    length: object | None = None,
    sigma_m: float | Tensor = 0.05,
    sigma_e: float | Tensor = 0.1,
    method: str = "auto",
    extra_variance: Tensor | None = None,
) -> Tensor:
    """Log-likelihood of Eq. (21) for a batch of model predictions and kernel parameters.

    The kernel matrix is built once per parameter vector and shared by its load cases; each
    load case adds its own diagonal ``sigma_m**2 eta_l**2 + sigma_e**2``. All covariances are
    factorised in batched Cholesky calls (in chunks of at most ``CHUNK_BYTES``); see
    :mod:`torchshm.likelihood.cholesky` for the jitter policy (a well-conditioned covariance is
    never perturbed). When ``sigma_m == 0`` the covariance is common to all load cases and is
    factorised once per parameter vector. The ``independent`` kernel needs no factorisation.

    The distribution is :class:`torchshm.likelihood.marginal.Eq21`, the same one the predictive
    draws sample from. For the Markov kernels (``exponential``, ``matern32``, ``matern52``) from
    :data:`~torchshm.likelihood.marginal.STATE_SPACE_FROM` points per load case, the exact
    density is computed from the kernel's state-space form in O(n) time and memory instead
    (any sorted or unsorted positions, repeats allowed; ``docs/likelihood.md``). For fields of
    `n x d` coordinates from :data:`~torchshm.likelihood.marginal.VECCHIA_FROM` points per load
    case, the full-scale approximation (low rank + nearest neighbours) is used instead of the
    dense covariance (:mod:`torchshm.likelihood.fullscale`; its measured error is in
    ``docs/likelihood.md``). All
    forms are differentiable by autograd, on CPU and CUDA tensors.

    Args:
        y: `L x n` measured strains [µε].
        eta: `... x L x n` model predictions [µε] (differentiable).
        x: `n` positions [m], or `n x d` coordinates [m] of a field (a kernel of the Euclidean
            distance; dense or Vecchia form, see :mod:`torchshm.likelihood.blocks`).
        kernel: a name from :data:`torchshm.kernels.KERNELS` or a :class:`Kernel`.
        sigma_a: discrepancy scale [µε], broadcastable to `...` (differentiable).
        length: correlation length [m], broadcastable to `...` (differentiable); ignored (may
            be ``None``) for a kernel without length such as ``independent``.
        sigma_m: standard deviation of the multiplicative model error (dimensionless), >= 0;
            a number, or a tensor broadcastable to `...` when it is inferred.
        sigma_e: standard deviation of the measurement noise [µε], >= 0; a number or a
            tensor broadcastable to `...`.
        method: ``"auto"`` (default), ``"dense"``, ``"state_space"`` or ``"hilbert"`` (1-D
            positions; the latter for ``squared_exponential``, reduced rank),
            ``"fullscale"`` or ``"vecchia"`` (`n x d` coordinates), ``"lattice"`` (kernel
            ``separable_exponential`` on a regular grid, exact and sparse, on the CPU).
        extra_variance: `... x L x n` variance [µε²] added to the diagonal of each load case's
            covariance, or None: e.g. an emulator's predictive variance of ``eta``, which makes
            the density the exact marginal over a Gaussian error of ``eta``.

    Returns:
        `...` log-likelihoods (float64 tensor; the batch shape is the broadcast of `eta`'s,
        `sigma_a`'s and `length`'s). -inf where a covariance cannot be factorised even with the
        largest jitter; NaN where an input is not finite or sigma_a or length is negative.

    Raises:
        ValueError: for an unknown kernel, mismatched shapes, a negative or non-finite
            ``sigma_m`` or ``sigma_e``, or a non-Markov kernel at a size whose dense covariance
            would not fit in memory.
    """
    kern = get_kernel(kernel)
    eta = as_float64(eta)
    y = as_float64(y).to(eta.device)
    x = as_float64(x).to(eta.device)
    _check_shapes(y, eta, x)
    sigma_m, sigma_e = _scale_arg("sigma_m", sigma_m, eta), _scale_arg("sigma_e", sigma_e, eta)
    if kern.has_length and length is None:
        raise ValueError(f"log_likelihood: kernel {kern.name!r} needs a length")
    sa = as_float64(sigma_a).to(eta.device)
    ell = as_float64(0.0 if not kern.has_length else length).to(eta.device)
    scales = [v.shape for v in (sigma_m, sigma_e) if isinstance(v, Tensor)]
    extra = None if extra_variance is None else as_float64(extra_variance).to(eta.device)
    try:
        batch = torch.broadcast_shapes(eta.shape[:-2], sa.shape, ell.shape, *scales,
                                       *([] if extra is None else [extra.shape[:-2]]))
    except RuntimeError:
        raise ValueError(
            f"log_likelihood: shapes of sigma_a {tuple(sa.shape)}, length {tuple(ell.shape)}, "
            f"sigma_m/sigma_e {scales} or extra_variance do not broadcast with eta's batch "
            f"{tuple(eta.shape[:-2])}"
        ) from None
    n_batch = math.prod(batch)
    eta_f = eta.expand(*batch, *y.shape).reshape(n_batch, *y.shape)
    sa_f, ell_f = sa.expand(batch).reshape(n_batch), ell.expand(batch).reshape(n_batch)
    sm_f, se_f = (v.expand(batch).reshape(n_batch) if isinstance(v, Tensor) else v
                  for v in (sigma_m, sigma_e))
    extra_f = None if extra is None else extra.expand(*batch, *y.shape).reshape(n_batch, *y.shape)
    dim = 1 if x.ndim == 1 else x.shape[1]
    positive = bool((se_f > 0).all()) if isinstance(se_f, Tensor) else se_f > 0
    form = choose_method(kern, y.shape[1], method, noise_positive=positive, dim=dim, x=x)
    shared = extra is None and not isinstance(sm_f, Tensor) and sm_f == 0.0
    matrices = 1 if shared else y.shape[0]  # covariances per parameter vector
    if form == "hilbert":  # the vectors it fits in chunks of their basis, the others dense
        fit = hilbert.fits(x, kern, ell_f)
        groups = [(torch.nonzero(fit)[:, 0], "hilbert"), (torch.nonzero(~fit)[:, 0], "dense")]
    else:
        groups = [(None, form)]
    parts, order = [], []
    for rows, part_form in groups:
        if rows is not None and not rows.numel():
            continue
        if part_form == "hilbert":  # B x L' x n x m factors, and as much again for the gradient
            basis = int(hilbert.sizes(x, kern, ell_f[rows]).max())
            step = max(1, STATE_SPACE_CHUNK_BYTES // (2 * matrices * y.shape[1] * basis * 8))
        elif part_form == "dense":
            step = max(1, CHUNK_BYTES // (matrices * y.shape[1] ** 2 * 8))
        else:
            step = max(1, STATE_SPACE_CHUNK_BYTES // (y.numel() * 8))
        every = torch.arange(n_batch, device=eta_f.device) if rows is None else rows
        for i in range(0, every.numel(), step):
            c = every[i:i + step] if rows is not None else slice(i, i + step)
            gaussian = Eq21(eta_f[c], x, kern, sa_f[c], ell_f[c], _part(sm_f, c), _part(se_f, c), part_form,
                            None if extra_f is None else extra_f[c])
            parts.append(gaussian.log_prob(y))
            order.append(every[i:i + step])
    if len(groups) == 1 or not parts:
        out = parts[0] if len(parts) == 1 else torch.cat(parts) if parts else eta_f.new_zeros(0)
    else:  # back in the vectors' order
        out = eta_f.new_empty(n_batch)
        out[torch.cat(order)] = torch.cat(parts)
    finite = torch.isfinite(eta_f).all(-1).all(-1) & torch.isfinite(sa_f) & torch.isfinite(ell_f)
    bad = ~finite | (sa_f < 0) | (ell_f < 0)
    for v in (sm_f, se_f):
        if isinstance(v, Tensor):
            bad = bad | ~torch.isfinite(v) | (v < 0)
    return torch.where(bad, torch.nan, out).reshape(batch)


def _scale_arg(name: str, value: object, like: Tensor) -> float | Tensor:
    """A scale as a float (checked) or, when it is a tensor with a batch, a float64 tensor
    (negative or non-finite entries give NaN log-likelihoods, as sigma_a's do)."""
    if isinstance(value, Tensor) and value.ndim:
        return as_float64(value).to(like.device)
    return _check_scale(name, value.item() if isinstance(value, Tensor) else value)


def _part(value: float | Tensor, part: slice) -> float | Tensor:
    return value[part] if isinstance(value, Tensor) else value


def _check_shapes(y: Tensor, eta: Tensor, x: Tensor) -> None:
    """Raise ``ValueError`` unless ``y`` is `L x n`, ``eta`` `... x L x n` and ``x`` `n` or `n x d`."""
    if y.ndim != 2 or 0 in y.shape:
        raise ValueError(f"log_likelihood: y must have shape (L, n), L, n >= 1, got {tuple(y.shape)}")
    if eta.ndim < 2 or eta.shape[-2:] != y.shape:
        raise ValueError(
            f"log_likelihood: eta must have shape (..., {y.shape[0]}, {y.shape[1]}) like y, "
            f"got {tuple(eta.shape)}"
        )
    if x.shape != (y.shape[1],) and not (x.ndim == 2 and x.shape[0] == y.shape[1] and x.shape[1] >= 1):
        raise ValueError(
            f"log_likelihood: x must have shape ({y.shape[1]},) or ({y.shape[1]}, d), got {tuple(x.shape)}"
        )


def _check_scale(name: str, value: float) -> float:
    """``value`` as a float; ``ValueError`` naming ``name`` when negative or not finite."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"log_likelihood: {name} must be a number, got {value!r}") from None
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"log_likelihood: {name} must be finite and >= 0, got {value}")
    return value
