"""How far the posterior may still be from the one the model itself would give.

The stop rule's total variation between successive rounds (:func:`.sampling.total_variation`)
measures how wrong the *previous* emulator was: it can only fall below its tolerance one round
after the emulator became good enough. The emulator's own uncertainty says the same thing one
round earlier. For a field emulator with mean ``m`` and shared latent posterior covariance
``K(θ, θ')`` (outputs ``j`` independent, ``e_j(θ) = a_j(θ) f_j(θ)`` with ``f_j`` of covariance
``K``), the log-likelihood error at the posterior draws is, to first order,

    Δ(θ) = Σ_j g_j(θ) e_j(θ),   Cov(Δ(θ), Δ(θ')) = c K(θ, θ') Σ_j g_j(θ) a_j(θ) g_j(θ') a_j(θ'),

with ``g = ∂ℓ/∂η`` at the emulator's mean (autograd through the problem's own likelihood, any
kernel and campaign) and ``c`` the emulator's calibration. Each joint draw of Δ over the
posterior draws reweights the posterior; the **witness** is the mean total variation between
the posterior and its reweightings, ``E_Δ ½ E_p |1 - e^Δ / E_p e^Δ|``: the total variation to
expect between this round's posterior and the next one's if the emulator's errors are as large
as it says (the batch check of :mod:`.validation` tests that they are). It is the larger of
this and the same with the error correlated across readings as the runs' fields are
(:meth:`EmulatedLogJoint.error_variance`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from torchshm.inference.adaptive.sampling import total_variation

if TYPE_CHECKING:
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

#: joint draws of the log-likelihood error over the posterior draws
N_FIELDS = 64
#: posterior draws the witness uses (the first ones given): the gradient of the likelihood at
#: each is most of its cost (0.2 s for 600 draws on the main job)
N_DRAWS = 300


def tv_witness(log_joint: EmulatedLogJoint, draws: np.ndarray, rng: np.random.Generator,
               n_fields: int = N_FIELDS, scale: float = 1.0) -> float:
    """Expected total variation between the posterior and the one of an emulator draw.

    Args:
        log_joint: the round's emulated log joint.
        draws: `S x D` posterior draws of it (inside the prior support, in random order: the
            first :data:`N_DRAWS` are used).
        rng: generator of the emulator draws.
        n_fields: number of joint draws of the log-likelihood error.
        scale: factor on the error's variance (:attr:`.validation.BatchCheck.witness_scale`:
            below 1 where the last batch's errors were far below the emulator's sd).

    Returns:
        The witness in [0, 1] (module docstring); 1 when it cannot be computed.
    """
    rows = np.atleast_2d(draws)[:N_DRAWS]
    if rows.shape[0] < 2:
        return 1.0
    mean, var, theta = log_joint.parts(rows)  # var: the calibrated (inflated) variance
    emulator = log_joint.emulator
    corr = emulator.latent_correlation(log_joint.problem.split.physical(theta))
    _, gradient = log_joint.gradient(mean, var, theta)
    g = (torch.nan_to_num(gradient * var.sqrt()) * log_joint.valid.to(var.dtype)).flatten(1)
    z = torch.as_tensor(rng.standard_normal((rows.shape[0], int(n_fields))))
    # the outputs' errors independent (as the emulator has them) and correlated as the runs'
    # fields are (as they come out, :meth:`EmulatedLogJoint.error_variance`): the larger TV
    return max(_mean_tv(scale * corr * (u @ u.mT), z) for u in (g, g @ emulator.error_basis))


def _mean_tv(cov: torch.Tensor, z: torch.Tensor) -> float:
    """Mean TV (:func:`.sampling.total_variation`) between the posterior (its draws uniform)
    and its reweightings by `F` draws ``Δ ~ N(0, cov)`` (`S x S`), from standard normal
    `S x F` ``z``."""
    top = float(cov.diagonal().max())
    if not np.isfinite(top):
        return 1.0
    if top < 1e-12:  # an sd below a micro-nat everywhere: no reweighting
        return 0.0
    eye = torch.eye(cov.shape[0], dtype=cov.dtype)
    try:
        w, v = torch.linalg.eigh(0.5 * (cov + cov.mT) / top + 1e-10 * eye)
    except RuntimeError:  # LinAlgError: an ill-conditioned matrix, no verdict
        return 1.0
    delta = ((v * (top * w.clamp_min(0.0)).sqrt()) @ z).mT.numpy()  # F x S
    if not np.isfinite(delta).all():
        return 1.0
    zero = np.zeros(delta.shape[1])
    return float(np.mean([total_variation(zero, d) for d in delta]))
