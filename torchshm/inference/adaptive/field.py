"""The field emulator of the adaptive method: a GP of the model's strain field over θp.

Only the physical parameters θp need the forward model; every run returns the strains of all
load cases at all positions. The emulator is the library's shared-kernel GP surrogate
(:mod:`torchshm.surrogate`), trained on the runs made so far and restricted to the measured
load cases and positions, so that the likelihood of any kernel, σa and l is cheap. Its latent
variance is shared by all outputs (one kernel), which makes the posterior covariance between
candidate points, needed by the batch rule, one small matrix product.

Transforms: a model may declare ``surrogate_transform`` (keywords of
:meth:`~torchshm.surrogate.ResponseTransform.fit`, or a fitted ``ResponseTransform``) when it
knows its structure (e.g. strains inversely proportional to a modulus); otherwise inputs are
scaled to the unit box and outputs standardised, which suits any model.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from torchshm.surrogate import ResponseTransform, Surrogate
from torchshm.surrogate.field import fit_field

#: the emulator's kernel by default (``emulator_kernel`` of the method; ``docs/surrogate.md``)
DEFAULT_KERNEL = "matern52_additive_warped"
#: transform keywords for a model that declares no structure
PLAIN_TRANSFORM: dict[str, Any] = {"log_inputs": (), "modulus": None, "relative_to_modulus": ()}


def model_transform(model: Any) -> dict[str, Any]:
    """Transform keywords for ``model``: its ``surrogate_transform`` if any, else plain scaling."""
    declared = getattr(model, "surrogate_transform", None)
    if declared is None:
        declared = getattr(model, "transform", None)  # a Surrogate used as the model
    if isinstance(declared, ResponseTransform):
        return {"log_inputs": declared.log_inputs, "modulus": declared.modulus,
                "relative_to_modulus": declared.relative_to_modulus}
    if isinstance(declared, dict):
        return {**PLAIN_TRANSFORM, **declared}
    return dict(PLAIN_TRANSFORM)


@dataclass
class FieldEmulator:
    """GP emulator of the measured strains `L x n` as a function of θp `P`.

    Attributes:
        surrogate: the fitted :class:`~torchshm.surrogate.Surrogate` (measured loads and
            positions only).
        theta_p: `N x P` distinct successful runs it was trained on [model units].
    """

    surrogate: Surrogate
    theta_p: Tensor

    @functools.cached_property
    def error_basis(self) -> Tensor:
        """`m x N` rows of unit length whose products are the correlations, across the runs,
        of the `m = L n` outputs (the GP's standardised targets).

        The emulator treats its outputs as independent, but its error at a new θp is a
        smooth field, correlated across readings as the runs' fields are: the error of reading
        `j` is modelled as ``sqrt(v_j) (B z)_j`` with `z` of `N` independent latent draws
        (:meth:`EmulatedLogJoint.error_variance`).
        """
        targets = self.surrogate.gp.train_targets  # m x N
        return targets / targets.norm(dim=-1, keepdim=True).clamp_min(1e-300)

    @classmethod
    def fit(cls, theta_p: np.ndarray, outputs: np.ndarray, x: Tensor, loads: Tensor,
            transform: dict[str, Any] | None = None, kernel: str = DEFAULT_KERNEL,
            previous: FieldEmulator | None = None) -> FieldEmulator:
        """Fit to runs ``theta_p`` `N x P` with measured strains ``outputs`` `N x L x n` [µε].

        The library's one GP fit (:func:`~torchshm.surrogate.field.fit_field`: failed and
        repeated runs left out, output compression). With ``previous`` (the last round's
        emulator) the marginal likelihood is maximised from its hyperparameters and from one
        fresh start, instead of three fresh starts. Raises ``ValueError`` with fewer than
        ``P + 2`` usable runs.
        """
        warm = None if previous is None else previous.surrogate.gp.hyperparameters()
        fit = fit_field(theta_p, outputs, transform=dict(PLAIN_TRANSFORM if transform is None else transform),
                        kernel=kernel, lengthscales=(0.2, 0.5, 1.0) if warm is None else (0.5,),
                        max_iter=100 if warm is None else 40, warm=warm, what="emulator")
        theta, out, gp, scaling, log_ml = (fit.theta_p, fit.outputs, fit.gp, fit.transform,
                                           fit.log_marginal_likelihood)
        names = tuple(f"theta_p[{i}]" for i in range(theta.shape[1]))
        sur = Surrogate(gp, scaling, x, loads, names, "adaptive-field-emulator", theta, out,
                        {"log_marginal_likelihood": log_ml})
        return cls(sur, theta)

    def predict(self, theta_p: Tensor) -> tuple[Tensor, Tensor]:
        """Mean [µε] and variance [µε²] of the strains, both `B x L x n`, at `B x P`."""
        with torch.no_grad():
            mean, var = self.surrogate.predict(theta_p)
        assert var is not None
        return mean, var.clamp_min(0.0)

    def predict_mean(self, theta_p: Tensor) -> Tensor:
        """Mean [µε] of the strains `B x L x n` at `B x P`, without the variance's solves."""
        with torch.no_grad():
            return self.surrogate.predict(theta_p, variance=False)[0]

    def latent_correlation(self, theta_p: Tensor) -> Tensor:
        """Posterior correlation `S x S` of the shared latent GP among θp `S x P`: how the
        emulator's errors at those points move together (its error at a point is its sd
        there times a draw of this correlation)."""
        cov = self.latent_covariance(theta_p, theta_p)
        sd = cov.diagonal().clamp_min(1e-300).sqrt()
        corr = cov / (sd[:, None] * sd[None, :])
        return 0.5 * (corr + corr.mT)

    def latent_covariance(self, a: Tensor, b: Tensor) -> Tensor:
        """Posterior covariance `A x B` of the shared latent GP between θp sets `A x P`, `B x P`.

        Divided by each point's own latent variance it gives how much a run at ``b`` reduces
        the emulator variance at ``a`` (variance reduction does not depend on the run's
        result, so a batch can be chosen before any of it is run).
        """
        gp, tr = self.surrogate.gp, self.surrogate.transform
        with torch.no_grad():
            ia, ib = tr.inputs(a), tr.inputs(b)
            prior = gp.covar_module(ia, ib).to_dense()
            factor = gp.factor
            sa = torch.linalg.solve_triangular(factor, gp.cross_covariance(ia).mT, upper=False)
            sb = torch.linalg.solve_triangular(factor, gp.cross_covariance(ib).mT, upper=False)
            return prior - sa.mT @ sb
