"""Live traces of a run: TensorBoard scalars and the in-memory history of the posterior.

:class:`RunTrace` receives one row of scalars per VBMC iteration (or per emcee checkpoint),
keeps it for :attr:`torchshm.inference.Posterior.history`, and, when a ``log_dir`` is given,
writes it at once to TensorBoard through ``torch.utils.tensorboard.SummaryWriter`` and flushes,
so a long run can be watched while it goes (``tensorboard --logdir <log_dir>``).

Tags: ``elbo``, ``elbo_sd``, ``sKL``, ``n_evaluations`` (VBMC); ``acceptance_fraction``,
``tau_max``, ``n_evaluations`` (emcee); for every parameter ``<name>/mean``, ``<name>/q2.5`` and
``<name>/q97.5``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from torchshm.inference.posterior import SUMMARY_QUANTILES


def marginal_scalars(names: list[str], samples: np.ndarray) -> dict[str, float]:
    """``<name>/mean``, ``<name>/q2.5``, ``<name>/q97.5`` of the columns of ``samples`` (`S x D`)."""
    mean = samples.mean(axis=0)
    lo, hi = np.quantile(samples, SUMMARY_QUANTILES, axis=0)
    out: dict[str, float] = {}
    for i, name in enumerate(names):
        out[f"{name}/mean"] = float(mean[i])
        out[f"{name}/q2.5"] = float(lo[i])
        out[f"{name}/q97.5"] = float(hi[i])
    return out


class RunTrace:
    """Collects per-iteration scalars and mirrors them to TensorBoard when asked.

    Args:
        log_dir: TensorBoard folder, or None to keep the trace in memory only.
        step_key: the key of each row used as TensorBoard step (``"iteration"`` for VBMC,
            ``"n_evaluations"`` for emcee).
    """

    def __init__(self, log_dir: str | Path | None, step_key: str) -> None:
        self.step_key = step_key
        self.rows: list[dict[str, float]] = []
        self._writer: Any = None
        if log_dir is not None:
            from torch.utils.tensorboard import SummaryWriter

            self._writer = SummaryWriter(log_dir=str(log_dir))

    def log(self, row: dict[str, float]) -> None:
        """Record one row (must contain ``step_key``); written and flushed at once."""
        self.rows.append(dict(row))
        if self._writer is None:
            return
        step = int(row[self.step_key])
        for tag, value in row.items():
            if tag != self.step_key:
                self._writer.add_scalar(tag, float(value), global_step=step)
        self._writer.flush()

    def history(self) -> dict[str, np.ndarray]:
        """The rows as columns: ``{key: 1-D float64 array}`` (NaN where a row lacks the key)."""
        keys: list[str] = []
        for row in self.rows:
            keys += [k for k in row if k not in keys]
        return {
            k: np.array([row.get(k, np.nan) for row in self.rows], dtype=np.float64) for k in keys
        }

    def close(self) -> None:
        """Flush and close the TensorBoard writer (the in-memory rows stay)."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
