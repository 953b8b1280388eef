"""Each new batch of model runs checks the emulator before it learns from them.

The batch was chosen among posterior draws of the emulated likelihood, so it is a fair test of
the emulator where the posterior lies. Three measures, all on runs the emulator has not seen:

- **calibration** ``c``: the mean of ``(y_run - m)² / (v + 1e-4 s²)`` over the runs' valid
  readings (the squared standardised error of the emulator's mean ``m`` against its own
  variance ``v``; ``s²`` is the data's own variance there, so errors far below the noise
  do not count).
  A calibrated GP gives ~1; ``c > 1`` means its errors are larger than it says. The next
  round's likelihood multiplies the emulator variance by ``max(1, c)`` (never narrower than
  the emulator's record allows);
- **log-likelihood error**: ``|ℓ(y_run) - ℓ(m)|`` [nats], Eq. (21) at the full parameter
  rows the runs came from, with the run's strains against the emulator's mean. The stop rule
  asks for its largest value over the batch to be below ``check_tol``: the emulator was right,
  in the units that move the posterior, where it was last tested;
- **the witness's bound** (:attr:`BatchCheck.witness_scale`): the same errors against the
  emulator's delta-method sd of the log-likelihood there (:meth:`EmulatedLogJoint.error_variance`,
  the sd the witness of :mod:`.witness` draws its reweightings from). Where the errors are
  far below it, the upper ``1 - WITNESS_LEVEL`` confidence bound of their variance ratio
  ``Σ (e / sd)² / χ²_{WITNESS_LEVEL}(b)`` scales the witness's variance down (never up: the
  calibration above already inflates it where the emulator errs more than it says).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch
from scipy.stats import chi2

#: share of the data's own variance (the Eq. 21 diagonal) below which an emulator error does
#: not count against its calibration (an error of 1 % of the data's sd moves nothing)
FLOOR = 1e-4
#: one-sided level of the bound on the emulator's log-likelihood error variance that scales
#: the witness (5 runs: the witness shrinks only where the batch's rms error / sd is below 0.48)
WITNESS_LEVEL = 0.05

if TYPE_CHECKING:
    from torchshm.inference.adaptive.field import FieldEmulator
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint


@dataclass(frozen=True)
class BatchCheck:
    """The emulator against one batch of new runs.

    Attributes:
        calibration: mean squared standardised error of the emulator at the runs (1: as
            predicted); NaN without runs.
        loglik_error: `b` absolute log-likelihood errors [nats] at the runs' parameter rows.
        loglik_sd: `b` the emulator's own predicted log-likelihood sd [nats] there (first
            order, independent readings: the stop rule's sd).
        error_sd: `b` its delta-method sd [nats] there, the error correlated across readings
            as the runs' fields are (:meth:`EmulatedLogJoint.error_variance`).
    """

    calibration: float
    loglik_error: np.ndarray
    loglik_sd: np.ndarray
    error_sd: np.ndarray | None = None

    @property
    def witness_scale(self) -> float:
        """Factor in (0, 1] on the witness's variance: the upper ``1 - WITNESS_LEVEL`` bound of
        the batch's ``E (e / sd)²`` (:attr:`error_sd`), capped at 1 (1 without runs)."""
        if self.error_sd is None or not self.loglik_error.size:
            return 1.0
        z2 = np.square(self.loglik_error / np.maximum(self.error_sd, 1e-300))
        if not np.isfinite(z2).all():
            return 1.0
        return float(min(1.0, z2.sum() / chi2.ppf(WITNESS_LEVEL, z2.size)))

    @property
    def max_error(self) -> float:
        """Largest log-likelihood error [nats] of the batch (inf without runs)."""
        return float(self.loglik_error.max()) if self.loglik_error.size else float("inf")

    def passed(self, tol: float) -> bool:
        """Whether every run of the batch was within ``tol`` nats of the emulator."""
        return bool(self.loglik_error.size) and self.max_error <= tol


def check_batch(log_joint: EmulatedLogJoint, emulator: FieldEmulator, rows: np.ndarray,
                outputs: np.ndarray) -> BatchCheck:
    """Compare ``emulator`` (not trained on them) with new runs.

    Args:
        log_joint: the emulated log joint of the round that chose the batch.
        emulator: the emulator of that round.
        rows: `b x D` full parameter rows the batch's θp came from (posterior draws).
        outputs: `b x L x n` the runs' strains [µε] at the measured readings (NaN: failed).
    """
    ok = np.isfinite(outputs).reshape(outputs.shape[0], -1).all(-1) if outputs.size else \
        np.zeros(outputs.shape[0], dtype=bool)
    rows, outputs = rows[ok], outputs[ok]
    if rows.shape[0] == 0:
        return BatchCheck(float("nan"), np.zeros(0), np.zeros(0))
    theta = torch.as_tensor(rows, dtype=torch.float64)
    mean, var = emulator.predict(log_joint.problem.split.physical(theta))
    run = torch.as_tensor(outputs, dtype=torch.float64)
    valid = log_joint.valid
    floor = FLOOR * log_joint.data_variance(mean, theta)  # errors far below the data's noise
    z2 = ((run - mean).square() / (var + floor))[:, valid]
    calibration = float(z2.mean())
    error = np.abs(log_joint.at(run, None, theta) - log_joint.at(mean, None, theta))
    _, sd = log_joint.emulator_share(rows)
    _, full = log_joint.value_and_sd(rows)
    return BatchCheck(calibration, error, sd, full)
