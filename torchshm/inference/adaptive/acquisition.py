"""Where to run the model next: a batch of θp where the emulator's uncertainty matters most.

The candidates are the physical parts of posterior draws. A candidate's utility is the
posterior-weighted variance of the log-likelihood that the emulator error causes there,
``u(θp) = mean over its draws of Σ_j v_j(θp) / s_j²`` (see
:meth:`EmulatedLogJoint.emulator_share`). The batch is chosen greedily: take the best
candidate, then lower every candidate's utility as if that run were already made (the shared
GP's variance after a run at θ* is ``v(θ) - c(θ, θ*)² / v(θ*)``, whatever its result: a
kriging believer that is exact for the variance), and repeat. A run close to one already
chosen thus loses its utility, which spreads the batch.
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
        ``(batch, gains)``: `b x P` chosen θp (b <= batch_size: fewer when candidates run out)
        and the utility each had when chosen.
    """
    theta_p = np.asarray(theta_p, dtype=np.float64)
    if theta_p.shape[0] > MAX_CANDIDATES:
        keep = rng.choice(theta_p.shape[0], MAX_CANDIDATES, replace=False)
        theta_p, utility = theta_p[keep], utility[keep]
    cand = torch.as_tensor(theta_p)
    cov = emulator.latent_covariance(cand, cand).numpy()
    var = np.clip(np.diag(cov).copy(), 1e-300, None)
    ratio = np.asarray(utility, dtype=np.float64) / var  # utility per unit latent variance
    current = var.copy()
    chosen: list[int] = []
    gains: list[float] = []
    for _ in range(int(batch_size)):
        score = ratio * current
        score[chosen] = -np.inf
        best = int(np.argmax(score))
        if not np.isfinite(score[best]) or score[best] <= 0:
            break
        chosen.append(best)
        gains.append(float(score[best]))
        c = cov[:, best].copy()
        cov = cov - np.outer(c, c) / max(c[best], 1e-300)
        current = np.clip(np.diag(cov), 0.0, None)
    return theta_p[chosen], np.array(gains)


def design(plausible: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` Latin hypercube points `n x P` in the box ``plausible`` `P x 2` (the first round)."""
    from scipy.stats import qmc

    sampler = qmc.LatinHypercube(d=plausible.shape[0], seed=np.random.default_rng([seed, 23]),
                                 optimization="random-cd")
    unit = sampler.random(int(n))
    return plausible[:, 0] + unit * (plausible[:, 1] - plausible[:, 0])
