"""Where to run the model next: a batch of θp where the emulator's uncertainty matters most.

The candidates are the physical parts of posterior draws, so a sum over them is a
posterior-weighted integral. Each carries the variance of the log-likelihood that the emulator
error causes there, ``u_i ≈ Σ_j v_j / s_j²`` (see :meth:`EmulatedLogJoint.emulator_share`).
A run at candidate b would remove the share ``ρ_ib²`` of it at every candidate i (ρ the
posterior correlation of the shared latent GP), so the expected integrated variance reduction
of a run at b is ``Σ_i u_i ρ_ib²``. The batch is chosen greedily: take the best candidate,
condition the GP's covariance on a run there (the variance after a run does not depend on its
result, so this "kriging believer" step is exact), scale every ``u_i`` by its variance
reduction, and repeat. Runs near one already chosen thus lose their value, which spreads the
batch.
"""

from __future__ import annotations

import numpy as np
import torch

from torchshm.inference.adaptive.field import FieldEmulator

#: largest number of candidates scored per batch (a random subset of the draws beyond)
MAX_CANDIDATES = 1500


def choose_batch(emulator: FieldEmulator, theta_p: np.ndarray, utility: np.ndarray,
                 batch_size: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A batch of ``batch_size`` distinct θp among candidates ``theta_p`` `C x P`.

    Args:
        emulator: the current field emulator.
        theta_p: candidate physical parameters (posterior draws).
        utility: `C` utility of each candidate (the emulated log-likelihood variance).
        batch_size: number of runs to choose.
        rng: generator for the candidate subset.

    Returns:
        ``(batch, index)``: `b x P` chosen θp (b <= batch_size: fewer when candidates run out)
        and their `b` row indices in ``theta_p``.
    """
    theta_p = np.asarray(theta_p, dtype=np.float64)
    keep = np.arange(theta_p.shape[0])
    if theta_p.shape[0] > MAX_CANDIDATES:
        keep = rng.choice(theta_p.shape[0], MAX_CANDIDATES, replace=False)
        theta_p, utility = theta_p[keep], utility[keep]
    cov = emulator.latent_covariance(*(torch.as_tensor(theta_p),) * 2).numpy()
    util = np.asarray(utility, dtype=np.float64).copy()
    chosen: list[int] = []
    gains: list[float] = []
    for _ in range(int(batch_size)):
        var = np.clip(np.diag(cov), 0.0, None)
        usable = var > 1e-9 * max(float(var.max()), 1e-300)
        scale = np.sqrt(np.where(usable, var, np.inf))
        corr2 = np.square(cov / scale[:, None] / scale[None, :])
        score = util @ corr2  # utility removed by a run at each candidate
        score[~usable] = -np.inf
        score[chosen] = -np.inf
        best = int(np.argmax(score))
        if not np.isfinite(score[best]) or score[best] <= 0:
            break
        chosen.append(best)
        gains.append(float(score[best]))
        c = cov[:, best].copy()
        cov = cov - np.outer(c, c) / max(c[best], 1e-300)
        new_var = np.clip(np.diag(cov), 0.0, None)
        util = util * np.where(usable, new_var / np.where(usable, var, 1.0), 0.0)
    return theta_p[chosen], keep[np.asarray(chosen, dtype=np.int64)]


def design(plausible: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` Latin hypercube points `n x P` in the box ``plausible`` `P x 2` (the first round)."""
    from scipy.stats import qmc

    sampler = qmc.LatinHypercube(d=plausible.shape[0], seed=np.random.default_rng([seed, 23]),
                                 optimization="random-cd")
    unit = sampler.random(int(n))
    return plausible[:, 0] + unit * (plausible[:, 1] - plausible[:, 0])
