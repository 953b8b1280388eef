"""The returned posterior must lie where the runs are, not only the round's chain.

The stop rule's condition on draws beyond the runs (``docs/inference.md`` step 7) looks at the
round's chain. The returned posterior comes from importance sampling whose proposal has slabs
over the plausible box (:func:`.final.posterior_draws`): they reach plateaus the chain barely
visits, and also the regions past the runs, where the emulator only extends what it saw. On
the held-out ``fresh10_p4`` (2026-11-29, in a run with an experimental flank test of the
exploration) the rule held after 41 runs with the chain inside the runs' range, and 2.4 % of
the returned draws lay at ``log10_k_C`` about 11.9, past the last run at 10.94, where the
emulated log joint was 9 nats (median) above the model's own: the spring's sd came out 3.1
times the reference's, in a run that said converged.

So a round whose stop rule holds draws a pilot of that importance sampling (:data:`PILOT`
draws from the same proposal, fitted to the round's chain). Where its draws beyond the runs
(:func:`.final.beyond_rows`) move its mean or sd of a parameter by more than :data:`TAIL_MOVE`
(in sds of its draws within the runs) the round is not converged, and the next batch runs the
model at the pilot's draw farthest out (:func:`.final.extrapolation_run`). A share of draws
would not do: 2.4 % of the mass 20 sds out triples an sd, and on ``fresh10_p4`` the pilot held
0.7 % beyond the runs where the final draws held 2.35 %.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.draws import DEFENSIVE, SLABS
from torchshm.inference.adaptive.final import beyond_rows
from torchshm.inference.adaptive.mixture import fit_mixture

if TYPE_CHECKING:
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

#: importance draws of the pilot
PILOT = 2000
#: largest move of a mean or sd (in sds of the draws within the runs) that the pilot's draws
#: beyond the runs may make
TAIL_MOVE = 0.05


def unseen_tail(log_joint: EmulatedLogJoint, chain: np.ndarray, columns: list[int],
                theta_p: np.ndarray, hard: np.ndarray, plausible: np.ndarray, seed: int,
                n: int = PILOT) -> tuple[np.ndarray, np.ndarray, float]:
    """Pilot draws of the final importance sampling and which of them lie beyond the runs.

    Args:
        log_joint: the round's emulated log joint.
        chain: `S x D` the round's chain, to which the proposal's mixture is fitted.
        columns: where the `P` physical parameters sit in a row.
        theta_p: `N x P` the runs' physical parameters.
        hard, plausible: `D x 2` search and plausible bounds.
        seed: seed of the mixture and the draws.
        n: pilot draws.

    Returns:
        ``(draws, beyond, move)``: the pilot's `n x D` draws (resampled by weight), `n`
        booleans (beyond the runs' range by more than :data:`.final.BEYOND_MARGIN` of a
        parameter's search range) and how far those move a physical parameter's mean or sd,
        at most, in sds of the draws within the runs (0 when none is beyond; inf when all are).
    """
    mix = fit_mixture(chain, sampling.transformer(hard, plausible), seed)
    pilot = sampling.importance(log_joint, mix.defensive(plausible, 2.0, DEFENSIVE, SLABS), n,
                                seed)
    draws, columns = pilot.draws, list(columns)
    beyond = beyond_rows(draws, columns, theta_p, hard)
    if not beyond.any():
        return draws, beyond, 0.0
    if beyond.all():
        return draws, beyond, float("inf")
    inside = draws[~beyond][:, columns]
    scale = np.maximum(inside.std(0), 1e-12)
    shift = np.abs(draws[:, columns].mean(0) - inside.mean(0)) / scale
    widen = np.abs(draws[:, columns].std(0) / scale - 1.0)
    return draws, beyond, float(max(shift.max(), widen.max()))


__all__ = ["PILOT", "TAIL_MOVE", "unseen_tail"]
