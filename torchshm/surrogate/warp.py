"""A learned monotone warp of each GP input: a kernel of inputs whose effect saturates.

A log-scale spring stiffness moves the strains only over a decade or two of its range (free
below, a clamp above): as a function of ``log10 k`` the field is an S-curve, flat at both ends
and steep in between. A stationary kernel has one lengthscale for the whole axis, short enough
for the steep part and so too short for the plateaus, whose runs then say nothing about each
other. Warping each unit-box input by the CDF of a Kumaraswamy distribution,
``K(u) = 1 - (1 - u^a)^b`` with concentrations ``a, b > 0`` fitted with the kernel's other
hyperparameters (Snoek, Swersky, Zemel and Adams 2014, "Input warping for Bayesian
optimization of non-stationary functions"; botorch's ``Warp`` input transform), stretches the
steep part and compresses the plateaus; ``a = b = 1`` is the identity.

The GP's inputs span the unit box of the design only, and the method predicts beyond it (the
box exploration, runs past the runs' range), where a CDF is not defined. So the warp is
``K`` on ``[ε, 1 - ε]`` mapped affinely onto ``[0, 1]``, continued linearly beyond ``[0, 1]``
with its end slopes (finite for ε > 0): monotone, continuous and defined on the whole line.
And the warp is ``u + λ (K(u) - u)`` with a fitted weight ``0 < λ <`` :data:`LAMBDA_MAX`: a
stretch of an input with few runs is never squeezed more than four times, which would make the
GP sure of it (measured: ``docs/surrogate.md``).
"""

from __future__ import annotations

import gpytorch
import torch
from torch import Tensor

#: the ends of the unit interval the Kumaraswamy CDF is read on, so that its end slopes are
#: finite (the linear continuation beyond the design's box)
EPS = 0.02
#: the concentrations' prior: log-normal around 1 (the identity), as botorch's ``Warp``
PRIOR_SD = 0.75 ** 0.5
#: the warp is ``(1 - λ) u + λ K(u)`` with ``λ`` at most this: its slope never falls below
#: ``1 - LAMBDA_MAX`` of the identity's, so no stretch of an input is compressed more than
#: ``1 / (1 - LAMBDA_MAX)`` times (a compressed stretch with few runs would look known)
LAMBDA_MAX = 0.75


class KumaraswamyWarp(gpytorch.Module):
    """Per-input monotone warp `... x d -> ... x d` of unit-box inputs (module docstring).

    Args:
        d: number of inputs; each has its own concentrations ``a, b`` and weight ``λ``.
    """

    def __init__(self, d: int) -> None:
        super().__init__()
        self.register_parameter("raw_a", torch.nn.Parameter(torch.zeros(d, dtype=torch.float64)))
        self.register_parameter("raw_b", torch.nn.Parameter(torch.zeros(d, dtype=torch.float64)))
        self.register_parameter("raw_mix", torch.nn.Parameter(torch.zeros(d, dtype=torch.float64)))

    @property
    def mix(self) -> Tensor:
        """`d` weights λ of the Kumaraswamy CDF against the identity, in (0, LAMBDA_MAX)."""
        return LAMBDA_MAX * torch.sigmoid(self.raw_mix)

    def log_prior(self) -> Tensor:
        """Log density of the concentrations under log-normal priors around 1 (a scalar; the
        raw parameters are their logs, so the normal density of those)."""
        raw = torch.cat([self.raw_a, self.raw_b])
        return torch.distributions.Normal(0.0, PRIOR_SD).log_prob(raw).sum()

    @property
    def a(self) -> Tensor:
        """`d` first concentrations (log-parametrised, > 0)."""
        return self.raw_a.exp()

    @property
    def b(self) -> Tensor:
        """`d` second concentrations (log-parametrised, > 0)."""
        return self.raw_b.exp()

    def reset(self) -> None:
        """Back to the identity (``a = b = 1``)."""
        with torch.no_grad():
            self.raw_a.zero_()
            self.raw_b.zero_()
            self.raw_mix.zero_()

    def _cdf(self, u: Tensor) -> Tensor:
        return 1.0 - (1.0 - u.pow(self.a)).pow(self.b)

    def _slope(self, u: Tensor) -> Tensor:
        a, b = self.a, self.b
        return a * b * u.pow(a - 1.0) * (1.0 - u.pow(a)).pow(b - 1.0)

    def forward(self, x: Tensor) -> Tensor:
        """The warped inputs, same shape as ``x`` (unit-box units)."""
        lo = torch.full_like(x[..., :1], EPS).expand_as(x)
        hi = torch.full_like(x[..., :1], 1.0 - EPS).expand_as(x)
        k_lo, k_hi = self._cdf(lo), self._cdf(hi)
        span = (k_hi - k_lo).clamp_min(1e-12)
        width = 1.0 - 2.0 * EPS
        u = EPS + width * x.clamp(0.0, 1.0)
        inside = (self._cdf(u.clamp(EPS, 1.0 - EPS)) - k_lo) / span
        below = x.clamp_max(0.0) * width * self._slope(lo) / span
        above = (x - 1.0).clamp_min(0.0) * width * self._slope(hi) / span
        warped = inside + below + above
        return x + self.mix * (warped - x)


class WarpedKernel(gpytorch.kernels.Kernel):
    """``k(W(x), W(x'))``: the kernel ``base`` of the warped inputs (:class:`KumaraswamyWarp`)."""

    def __init__(self, base: gpytorch.kernels.Kernel, d: int) -> None:
        super().__init__()
        self.base = base
        self.warp = KumaraswamyWarp(d)

    def forward(self, x1: Tensor, x2: Tensor, diag: bool = False, **params: object) -> Tensor:
        w1 = self.warp(x1)
        w2 = w1 if x2 is x1 else self.warp(x2)
        return self.base(w1, w2, diag=diag, **params)
