"""The emulator method's own compute, estimated before the first model run.

Each round evaluates the emulated likelihood at about ``1.5 n_walkers n_steps`` parameter
vectors (the chain, the mode search, the exploration's Sobol points; twice that in round 0) and
the end at about ``n_evidence + n_walkers final_steps`` (measured on the main job: 7,400 vectors
a round, 10,600 in round 0, 12,000 at the end, for 96 walkers and 50 steps). On a fibre of a few
hundred readings a vector costs a fraction of a millisecond in a batch; on a camera field with
a sparse density per vector (kernel ``upscaled``: one elimination of the element grid per vector,
about 0.2 s at 1.5e5 points) a round costs half an hour or more, longer than the model runs it saves.
So before the design's runs the likelihood is timed once at rows drawn from the prior, with the
data standing in for the emulator's mean (the cost does not depend on the values), and a round
whose estimate exceeds :data:`WARN_ROUND_S` is announced with its figures and the alternative.
"""

from __future__ import annotations

import logging
import time
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from torchshm.inference.adaptive import unsure
from torchshm.inference.adaptive.draws import MAX_PASSES
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger("torchshm.inference.adaptive.method")

#: vectors evaluated per round, in units of ``n_walkers * n_steps`` (measured, module docstring)
ROUND_FACTOR = 1.5
#: an estimated round of own compute above this many CPU seconds is announced as a warning
WARN_ROUND_S = 300.0
#: the batch timed after the first vector is half the walkers unless that would take longer
#: than this many CPU seconds at the first vector's cost (then four vectors)
TIMING_S = 2.0


@dataclass(frozen=True)
class OwnCost:
    """Estimated own compute of :func:`~.method.run_emulator` (CPU seconds).

    Attributes:
        per_vector: one parameter vector of the emulated likelihood, in a batch.
        per_round: one round (round 0 costs about twice as much).
        final: the final chain, density and evidence.
        capped: more at the end when the cap ends the run before the stop rule holds (the
            posterior averaged over the emulator's errors, :mod:`.unsure`, on
            :data:`~.unsure.N_POINTS` points).
        capped_most: the same average made again on up to :data:`~.unsure.MAX_POINTS` points,
            where the first keeps fewer than :data:`~.unsure.MIN_ESS` effective draws (known only
            after it; many parameters).
        final_most: ``final`` with the importance passes drawn where a moment's tail needs
            them (:data:`~.draws.MAX_PASSES` more of ``n_evidence``; known only at the end).
    """

    per_vector: float
    per_round: float
    final: float
    capped: float = 0.0
    capped_most: float = 0.0
    final_most: float = 0.0


def estimate(problem: Problem, n_walkers: int, n_steps: int, final_steps: int, n_evidence: int,
             rng: np.random.Generator, error_draws: int | None = None) -> OwnCost:
    """Time the problem's likelihood on prior rows and scale it to a round and to the end.

    One vector is timed first (which also warms any cached plan up), then a batch: half the
    walkers (the size of emcee's calls: batched forms cost far less per vector than a lone
    call, e.g. 23 ms for 48 vectors against 14 ms for one on two fibres with dropouts), or
    four vectors when that batch would take more than :data:`TIMING_S` (the sparse forms cost
    the same per vector in a batch); the batch's mean is the per-vector cost.
    """
    lj = EmulatedLogJoint(problem, None)  # type: ignore[arg-type]  # `at` needs no emulator
    mean = torch.nan_to_num(torch.as_tensor(problem.y, dtype=torch.float64))

    # timed as the chain, the mode search, the final step and the capped average call it: the
    # plug-in likelihood without the emulator's variance (only the exploration's and the
    # witness's few hundred points a round add it), so a density that factorises once for load
    # cases of equal noise (sigma_m = 0) is timed as it runs

    def seconds(k: int) -> float:
        rows = torch.as_tensor(np.atleast_2d(problem.sample_prior(k, rng)), dtype=torch.float64)
        start = time.process_time()
        lj.at(mean.expand(k, *mean.shape), None, rows)
        return time.process_time() - start

    one = seconds(1)  # also the warm-up of any cached plan
    half = max(4, n_walkers // 2)  # the size of emcee's calls
    k = half if one * half <= TIMING_S else 4
    per = seconds(k) / k
    per_round = ROUND_FACTOR * n_walkers * n_steps * per
    per_pass = unsure.N_POINTS * per  # one pass of Eq. (21) over the average's points
    capped = (1 + unsure.fields_for(per_pass, error_draws)) * per_pass
    most = unsure.MAX_POINTS * per
    final = (n_evidence + n_walkers * final_steps) * per
    return OwnCost(per, per_round, final, capped,
                   capped + (1 + unsure.fields_for(most, error_draws)) * most,
                   final + MAX_PASSES * n_evidence * per)


def duration(seconds: float) -> str:
    """``seconds`` as ``"12 s"``, ``"31 min"`` or ``"2.1 h"``."""
    if seconds < 120:
        return f"{seconds:.2g} s"
    return f"{seconds / 60:.0f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h"


def announce(problem: Problem, cost: OwnCost) -> None:
    """Log the estimate; a RuntimeWarning instead when a round exceeds :data:`WARN_ROUND_S`."""
    n = int(np.prod(problem.y.shape))
    text = (f"method='emulator': the emulated likelihood costs about {cost.per_vector:.2g} s of "
            f"CPU per parameter vector here ({n} readings, kernel {problem.kernel.name!r}), "
            f"so about {duration(cost.per_round)} of own compute per round (twice that in "
            f"round 0) and {duration(cost.final)} at the end (up to {duration(cost.final_most)} "
            "where a tail of the posterior needs more importance draws; "
            f"{duration(cost.capped)} more if the "
            f"cap ends the run before the stop rule holds, up to {duration(cost.capped_most)} where "
            f"that average has to be made again on more points)")
    if cost.per_round <= WARN_ROUND_S:
        logger.info(text)
        return
    text += ("; it evaluates the likelihood thousands of times a round without the model: prefer "
             "method='vbmc' here (about one evaluation per model run) or a coarser view of the "
             "data (fewer points)")
    warnings.warn(text, RuntimeWarning, stacklevel=4)  # the CLI logs it (logging.captureWarnings)


__all__ = ["OwnCost", "ROUND_FACTOR", "TIMING_S", "WARN_ROUND_S", "announce", "duration", "estimate"]
