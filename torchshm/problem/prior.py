"""The joint prior of the inferred parameters: independent priors, one per column.

One object gives the log density and the draws that :class:`~torchshm.problem.Problem`,
:class:`~torchshm.inference.Posterior` and :func:`~torchshm.predictive.kl_divergence` use, so
the prior of a run is evaluated the same way wherever it is needed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import torch
from torch import Tensor

from torchshm.arrays import as_float64


class JointPrior:
    """Product of independent priors over the columns of a parameter vector `D`.

    Args:
        priors: name -> prior (an object with ``log_prob``; ``sample``, ``hard_bounds`` and
            ``plausible_bounds`` too for the methods that use them) or a number (fixed).
        names: the `D` inferred parameters, in column order; each must have a prior.

    Raises:
        ValueError: naming a parameter that is missing from ``priors`` or whose prior has no
            ``log_prob``.
    """

    def __init__(self, priors: Mapping[str, object], names: Sequence[str]) -> None:
        self.names = [str(n) for n in names]
        for name in self.names:
            if name not in priors:
                raise ValueError(f"prior: no prior for the inferred parameter {name!r}")
            if not hasattr(priors[name], "log_prob"):
                raise ValueError(
                    f"prior: parameter {name!r} is inferred but its prior {priors[name]!r} "
                    "has no log_prob"
                )
        self.components = [priors[n] for n in self.names]

    @property
    def dim(self) -> int:
        """Number of inferred parameters `D`."""
        return len(self.names)

    def log_prob(self, theta: object) -> Tensor | np.ndarray:
        """Log density `...` of ``theta`` (`... x D`), numpy in numpy out, torch in torch out.

        -inf (never NaN) outside the support. Differentiable for a tensor ``theta``.
        """
        t = as_float64(theta)
        if t.ndim == 0 or t.shape[-1] != self.dim:
            raise ValueError(
                f"theta must have shape (..., {self.dim}) for {self.names}, got {tuple(t.shape)}"
            )
        total = t.new_zeros(t.shape[:-1])
        for k, prior in enumerate(self.components):
            total = total + as_float64(prior.log_prob(t[..., k]))  # type: ignore[attr-defined]
        total = torch.where(torch.isnan(total), -torch.inf, total)
        return total if isinstance(theta, Tensor) else total.detach().numpy()[()]

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """`n x D` independent draws (each prior's ``sample(n, rng)``, in column order)."""
        rng = np.random.default_rng(rng)
        cols = [prior.sample(n, rng) for prior in self.components]  # type: ignore[attr-defined]
        return np.column_stack(cols) if cols else np.zeros((int(n), 0))

    @property
    def hard_bounds(self) -> np.ndarray:
        """`D x 2` hard bounds (outside them the density is zero)."""
        return np.array([p.hard_bounds for p in self.components], dtype=np.float64).reshape(-1, 2)  # type: ignore[attr-defined]

    @property
    def plausible_bounds(self) -> np.ndarray:
        """`D x 2` plausible bounds (where most of the prior mass lies)."""
        return np.array(  # type: ignore[attr-defined]
            [p.plausible_bounds for p in self.components], dtype=np.float64  # type: ignore[attr-defined]
        ).reshape(-1, 2)

    def __repr__(self) -> str:
        return f"JointPrior({dict(zip(self.names, self.components))!r})"
