"""The Gaussian of Eq. (21), built in one place for the likelihood and the predictive draws.

For load case ``l`` of a parameter vector with model response ``eta_l`` (`n`)::

    y_l ~ N(eta_l, sigma_m**2 diag(eta_l)**2 + K + sigma_e**2 I)

:class:`Eq21` is that distribution for a batch of parameter vectors, in the spirit of GPyTorch's
``Likelihood.marginal``: :meth:`Eq21.log_prob` gives the log-likelihood and :meth:`Eq21.sample`
the posterior predictive draws (Eq. 15), from the same covariance, in one of these forms
(``docs/likelihood.md``): ``"dense"`` (:func:`covariance`, batched Cholesky, any kernel),
``"state_space"`` (Markov kernels, exact, O(n), :mod:`~torchshm.likelihood.statespace`),
``"hilbert"`` (a Gaussian spectral density along a line, reduced rank, within 2e-5 nat,
:mod:`~torchshm.likelihood.hilbert`; draws are dense),
``"vecchia"`` and ``"fullscale"`` (fields of `n x d` coordinates, approximate), all
differentiable on CPU or CUDA; ``"upscaled"`` (kernel ``upscaled``, exact, sparse, NumPy/SciPy,
:mod:`~torchshm.likelihood.upscaled`) and ``"lattice"`` (kernel ``separable_exponential`` on a
regular grid, exact, sparse, differentiable, CPU, :mod:`~torchshm.likelihood.lattice`). ``method="auto"``
(:func:`~torchshm.likelihood.choice.choose_method`) takes the state space from
:data:`STATE_SPACE_FROM` points per load case, the full-scale form for fields from
:data:`VECCHIA_FROM`, and refuses, with one line, a dense covariance that would not fit in memory.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import torch
from torch import Tensor

from torchshm.kernels import Kernel
from torchshm.likelihood import fullscale, hilbert, lattice, statespace, upscaled, vecchia
from torchshm.likelihood.choice import (  # the choice of form, and its thresholds, re-exported
    DENSE_MEMORY_SHARE,
    FULLSCALE_NEIGHBOURS,
    FULLSCALE_RANK,
    HILBERT_FROM,
    STATE_SPACE_FROM,
    VECCHIA_FROM,
    choose_method,
)
from torchshm.likelihood.cholesky import cholesky_with_jitter
from torchshm.likelihood.constants import LOG_2PI
from torchshm.likelihood.dense import dense_log_density

logger = logging.getLogger(__name__)
#: seconds between two progress lines of long dense draws
PROGRESS_EVERY_S = 15.0

#: largest dense covariance batch [bytes] built and factorised at once when sampling
SAMPLE_CHUNK_BYTES = 2**21


def covariance(x: Tensor, kern: Kernel, sigma_a: Tensor, length: Tensor, noise: Tensor) -> Tensor:
    """Dense covariances ``K + diag(noise)`` `B x L' x n x n` [µε²].

    Args:
        x: `n` positions [m].
        kern: the discrepancy kernel.
        sigma_a: `B` scales [µε]; length: `B` correlation lengths [m].
        noise: `B x L' x n` diagonal [µε²].
    """
    n = x.shape[0]
    cov = kern(x, sigma_a=sigma_a, length=length)[:, None].expand(-1, noise.shape[1], n, n).clone()
    cov.diagonal(dim1=-2, dim2=-1).add_(noise)
    return cov


@dataclass
class Eq21:
    """The Gaussian of Eq. (21) for `B` parameter vectors and `L` load cases.

    Attributes:
        eta: `B x L x n` model responses [µε].
        x: `n` positions [m], or `n x d` coordinates [m] (dense or diagonal forms only).
        kern: the discrepancy kernel.
        sigma_a: `B` discrepancy scales [µε]; length: `B` correlation lengths [m].
        sigma_m: multiplicative model error (dimensionless); sigma_e: noise sd [µε]; each
            one number, or a `B` tensor (one per parameter vector, when they are inferred).
        method: ``"auto"``, ``"dense"``, ``"state_space"``, ``"fullscale"``, ``"vecchia"`` or
            ``"lattice"`` (see :func:`choose_method`).
        extra: `B x L x n` variance [µε²] added to the diagonal, or None: e.g. an emulator's
            predictive variance of ``eta`` (the exact marginal over a Gaussian error of it).
    """

    eta: Tensor
    x: Tensor
    kern: Kernel
    sigma_a: Tensor
    length: Tensor
    sigma_m: float | Tensor
    sigma_e: float | Tensor
    method: str = "auto"
    extra: Tensor | None = None

    def __post_init__(self) -> None:
        self.method = choose_method(self.kern, self.x.shape[0], self.method, dim=_dim(self.x), x=self.x)

    def _noise(self) -> Tensor:
        """The diagonal ``sigma_e² + sigma_m² eta² (+ extra)`` `B x L x n` [µε²]."""
        noise = _rows(self.sigma_e, self.eta).square() + _rows(self.sigma_m, self.eta).square() * self.eta.square()
        return noise if self.extra is None else noise + self.extra

    @property
    def _shared_noise(self) -> bool:
        """Whether the diagonal is the same for every load case (one factor per vector)."""
        return self.extra is None and not isinstance(self.sigma_m, Tensor) and self.sigma_m == 0.0

    def log_prob(self, y: Tensor) -> Tensor:
        """Log densities `B` of ``y`` (`L x n`), summed over load cases; -inf where a dense
        covariance cannot be factorised even with the largest jitter (differentiable)."""
        resid = y - self.eta
        noise = self._noise()  # B x L x n
        if self.method == "diagonal":
            var = self.kern.diag(_points(self.x), sigma_a=self.sigma_a)[:, None, :] + noise
            singular = (var <= 0).any(-1).any(-1)
            var = torch.where(var > 0, var, 1.0)
            terms = resid.square() / var + var.log() + LOG_2PI
            return torch.where(singular, -torch.inf, -0.5 * terms.sum((-1, -2)))
        if self.method == "state_space":
            order = self._order()
            if bool((order[1:] < order[:-1]).any()):  # unsorted positions: gather (sorted: as they are)
                resid, noise, x = resid[..., order], noise[..., order], self.x[order]
            else:
                x = self.x
            return statespace.log_density(resid, noise, x, self.kern, self.sigma_a, self.length)
        if self.method in ("upscaled", "lattice"):
            form = upscaled if self.method == "upscaled" else lattice
            return form.log_density(resid, noise, self.x, self.sigma_a, self.length)
        if self.method == "vecchia":
            return vecchia.log_density(resid, noise, self.x, self.kern, self.sigma_a, self.length)
        if self.method == "fullscale":
            return fullscale.log_density(resid, noise, self.x, self.kern, self.sigma_a, self.length)
        if self.method == "hilbert":
            return self._hilbert(resid, noise)
        return self._dense(resid, noise, self.sigma_a, self.length)

    def _dense(self, resid: Tensor, noise: Tensor, sigma_a: Tensor, length: Tensor) -> Tensor:
        """Dense log densities `B` of ``resid`` with diagonal ``noise`` (both `B x L x n`)."""
        if self._shared_noise:
            noise = noise[:, :1]  # identical for every load case: one factorisation
        cov = covariance(self.x, self.kern, sigma_a, length, noise)
        return dense_log_density(cov, resid)  # its gradient in closed form

    def _hilbert(self, resid: Tensor, noise: Tensor) -> Tensor:
        """The reduced-rank form for the rows it fits, the dense form for the others."""
        rows = hilbert.fits(self.x, self.kern, self.length)
        if bool(rows.all()):
            return hilbert.log_density(resid, noise, self.x, self.kern, self.sigma_a, self.length, self._shared_noise)
        out = resid.new_empty(resid.shape[0])
        if bool(rows.any()):
            out[rows] = hilbert.log_density(resid[rows], noise[rows], self.x, self.kern, self.sigma_a[rows],
                                            self.length[rows], self._shared_noise)
        rest = ~rows
        out[rest] = self._dense(resid[rest], noise[rest], self.sigma_a[rest], self.length[rest])
        return out

    def sample(self, generator: torch.Generator) -> Tensor:
        """One draw `B x L x n` per response: ``eta + sigma_m eta z1 + f + e``.

        Standard normals come from ``generator`` in a fixed order: `B x L x n` for the
        multiplicative term, then for the dense and diagonal forms `B x L x n` multiplied by the
        factor of ``K + sigma_e**2 I`` (for the Vecchia form, its sparse factor in Vecchia
        order, :func:`~torchshm.likelihood.vecchia.sample`); for the state space process noise
        block by block (:func:`~torchshm.likelihood.statespace.sample`), then `B x L x n`
        measurement noise.

        Raises:
            ValueError: if a dense discrepancy covariance is not positive definite.
        """
        eta, x = self.eta, self.x
        z1 = torch.randn(eta.shape, generator=generator, dtype=torch.float64).to(eta.device)
        out = eta + _rows(self.sigma_m, eta) * eta * z1
        sigma_e = _rows(self.sigma_e, eta)
        if self.method == "state_space":
            order = self._order()
            f = statespace.sample(x[order], self.kern, self.sigma_a, self.length, eta.shape[1], generator)
            e = torch.randn(eta.shape, generator=generator, dtype=torch.float64).to(eta.device)
            if bool((order[1:] > order[:-1]).all()):  # sorted positions: no gather and scatter
                out += f + sigma_e * e
                return out
            out[..., order] += f + (sigma_e * e)[..., order]
            return out
        if self.method in ("upscaled", "lattice"):
            form = upscaled if self.method == "upscaled" else lattice
            f = form.sample(x, self.sigma_a, self.length, eta.shape[1], generator)
            return out + f + sigma_e * torch.randn(eta.shape, generator=generator, dtype=torch.float64).to(eta.device)
        z2 = torch.randn(eta.shape, generator=generator, dtype=torch.float64).to(eta.device)
        if self.method in ("vecchia", "fullscale"):  # draws: the Vecchia factor (docs/likelihood.md)
            if isinstance(self.sigma_e, Tensor) and self.sigma_e.ndim:  # inferred: one level per row
                return out + torch.cat([vecchia.sample(x, self.kern, self.sigma_a[i:i + 1], self.length[i:i + 1],
                                                       float(self.sigma_e[i]) ** 2, z2[i:i + 1])
                                        for i in range(eta.shape[0])])
            return out + vecchia.sample(x, self.kern, self.sigma_a, self.length, float(self.sigma_e) ** 2, z2)
        if self.method == "diagonal":
            sd = (self.kern.diag(_points(x), sigma_a=self.sigma_a)[:, None, :] + sigma_e.square()).sqrt()
            return out + sd * z2
        n = x.shape[0]
        step = max(1, SAMPLE_CHUNK_BYTES // (n * n * 8))
        said = time.monotonic()
        for start in range(0, eta.shape[0], step):
            if time.monotonic() - said > PROGRESS_EVERY_S:
                logger.info("drawing: %d of %d parameter vectors done", start, eta.shape[0])
                said = time.monotonic()
            part = slice(start, start + step)
            noise = sigma_e[part].square().expand(-1, 1, eta.shape[-1])
            cov = covariance(x, self.kern, self.sigma_a[part], self.length[part], noise)
            chol, failed = cholesky_with_jitter(cov)
            if bool(failed.any()):
                raise ValueError("predictive draws: a discrepancy covariance is not positive definite")
            out[part] += torch.matmul(chol[:, 0], z2[part].mT).mT
        return out

    def _order(self) -> Tensor:
        """Indices that sort the positions (the state space runs along ascending ``x``)."""
        return torch.argsort(self.x, stable=True)


def _dim(x: Tensor) -> int:
    """Dimension of positions `n` (1) or coordinates `n x d` (d)."""
    return 1 if x.ndim == 1 else int(x.shape[-1])


def _points(x: Tensor) -> Tensor:
    """`n` values standing for the `n` points of ``x`` (the diagonal needs their number only)."""
    return x if x.ndim == 1 else x[:, 0]


def _rows(value: float | Tensor, like: Tensor) -> Tensor:
    """A number or a `B` tensor as a `B x 1 x 1` (or scalar) tensor that broadcasts with
    `B x L x n` ``like``."""
    if isinstance(value, Tensor) and value.ndim:
        return value.to(like).reshape(-1, 1, 1)
    return torch.as_tensor(float(value), dtype=like.dtype, device=like.device).reshape(1, 1, 1).expand(like.shape[0], 1, 1)
