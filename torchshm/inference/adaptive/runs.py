"""Model runs of the adaptive method: a batch of θp evaluated concurrently, through the store.

With a store, a batch goes to :func:`torchshm.storage.evaluate` (joblib processes or submitit
jobs run it concurrently; every finished run is persisted at once, so a run killed mid-batch
loses only the runs in flight, and a rerun finds the finished ones). Without a store the batch
is evaluated in this process through the problem (its cache keeps the outputs for the
posterior predictive); parallel evaluation then needs a store, where workers leave results.
A failed run is recorded (in the store) and left out of the emulator; it never stops the run.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from torchshm.forward.protocol import output_shape
from torchshm.storage import canonical_theta, evaluate

if TYPE_CHECKING:
    from torchshm.problem import Problem


@dataclass
class RunSet:
    """Every successful run known to the method, at the measured loads and positions.

    Attributes:
        theta_p: `N x P` physical parameters [model units].
        outputs: `N x L x n` strains [µε] at the measured load cases and positions.
        n_new: model runs this identification made (store hits excluded).
        n_failed: runs of this identification that failed (left out).
    """

    theta_p: np.ndarray
    outputs: np.ndarray
    n_new: int = 0
    n_failed: int = 0
    errors: list[str] = field(default_factory=list)

    @classmethod
    def from_problem(cls, problem: Problem) -> RunSet:
        """The runs already in the problem's store (another kernel's or resolution's)."""
        theta_p, outputs = problem.evaluations()
        out = measured(problem, np.asarray(outputs, dtype=np.float64))
        n_phys = len(problem.physical_names)
        return cls(np.asarray(theta_p, dtype=np.float64).reshape(out.shape[0], n_phys), out)

    def add(self, theta_p: np.ndarray, outputs: np.ndarray) -> None:
        """Append successful runs not held yet (rows of `B x P`, `B x L x n`)."""
        known = {tuple(np.round(r, 10)) for r in self.theta_p.tolist()}
        for row, out in zip(theta_p, outputs):
            key = tuple(np.round(row, 10))
            if key not in known and np.isfinite(out).all():
                known.add(key)
                self.theta_p = np.vstack([self.theta_p, row[None]])
                self.outputs = np.concatenate([self.outputs, out[None]])


def measured(problem: Problem, outputs: np.ndarray) -> np.ndarray:
    """Model outputs `N x L_model x n_model` at the measured loads and positions `N x L x n`
    (exact or interpolated: :meth:`Problem.at_measured`)."""
    if outputs.shape[0] == 0:
        return np.zeros((0, *tuple(problem.y.shape)))
    return problem.at_measured(torch.as_tensor(outputs, dtype=torch.float64)).numpy()


def run_batch(problem: Problem, runs: RunSet, theta_p: np.ndarray, n_jobs: int = 1,
              executor: Any | None = None) -> tuple[int, np.ndarray]:
    """Evaluate `B x P` physical parameters, add the successful runs to ``runs``.

    Returns:
        ``(n_new, outputs)``: the number of new model runs made (store hits excluded) and the
        `B x L x n` strains [µε] at the measured readings, row by row (NaN where a run failed).

    Raises:
        ValueError: when ``n_jobs != 1`` or an executor is asked for a problem without store.
    """
    if theta_p.shape[0] == 0:
        return 0, np.zeros((0, *tuple(problem.y.shape)))
    theta_p = canonical_theta(theta_p)  # as the store keys it: a rerun sees the same values
    store, model = getattr(problem, "store", None), problem.model
    if n_jobs == 1 and executor is None and all(
            hasattr(model, a) for a in ("model", "n_jobs", "executor")):
        model, n_jobs, executor = model.model, model.n_jobs, model.executor  # a ParallelModel
    if store is None:
        if (n_jobs != 1 or executor is not None) and model is problem.model:
            raise ValueError("method='emulator': parallel runs (n_jobs or executor) need a "
                             "problem with a store, where each worker leaves its result")
        outputs, new, errors = _through_problem(problem, theta_p)
        ok = np.isfinite(outputs.reshape(outputs.shape[0], -1)).all(-1)
    else:
        result = evaluate(model, theta_p, store=store, n_jobs=n_jobs, executor=executor)
        outputs, ok, new = result.outputs, result.ok, int(result.n_new)
        errors = [f"θp={result.theta_p[i].tolist()}: {result.errors[i]}"
                  for i in np.flatnonzero(~ok)]
    runs.n_new += new
    runs.n_failed += int((~ok).sum())
    runs.errors += errors
    if errors:
        warnings.warn(f"method='emulator': {len(errors)} model runs failed and are left out: "
                      + "; ".join(e.splitlines()[0] for e in errors), RuntimeWarning, stacklevel=3)
    at = np.full((theta_p.shape[0], *tuple(problem.y.shape)), np.nan)
    at[ok] = measured(problem, outputs[ok])
    runs.add(theta_p[ok], at[ok])
    return new, at


def _through_problem(problem: Problem, theta_p: np.ndarray) -> tuple[np.ndarray, int, list[str]]:
    """Outputs `B x L_model x n_model` of rows evaluated one by one through the problem (whose
    cache keeps them); a run that raises or returns non-finite strains gives NaN."""
    before = int(problem.n_model_evaluations)
    rows, errors = [], []
    for row in theta_p:
        try:
            out = np.asarray(problem.model_outputs(row[None]), dtype=np.float64)[0]
        except Exception as exc:  # a failed run is recorded and left out, never fatal
            errors.append(f"θp={row.tolist()}: {type(exc).__name__}: {exc}")
            out = np.full(output_shape(problem.model), np.nan)
        else:
            if not np.isfinite(out).all():
                errors.append(f"θp={row.tolist()}: non-finite output")
        rows.append(out)
    return np.stack(rows), int(problem.n_model_evaluations) - before, errors
