"""The log joint as an inference method sees it: counted, recorded, and never fatal.

:class:`LogJointTarget` wraps ``problem.log_joint``. Every evaluation goes through the problem
(and so through its evaluation store, where the model outputs of all load cases are kept).
Each point the method asks for is appended, before it is evaluated, to a small *point log*
next to the store (:class:`PointLog`), so a later run on the same store can hand the
previous run's points to the method again without a new model evaluation.

A failed model run gives a non-finite log joint inside the support (a model that raises is
caught by the problem's cache; one that gets past it is caught here: the point's log joint is then
NaN). When no point evaluated so far has a finite log joint and model runs failed, the run stops
with :class:`ModelRunsFailed`, one line quoting the first model error. emcee treats such a point
as having zero density (the proposal is rejected). PyVBMC refuses non-finite values, so for
VBMC the point gets the lowest log joint observed so far (a pessimistic imputation), and the run
goes on; every failure is counted and reported in the posterior's diagnostics.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from torchshm.forward.protocol import model_identity

if TYPE_CHECKING:
    from torchshm.problem import Problem


def store_path(problem: Problem) -> Path | None:
    """Path of the problem's evaluation store, or None when it has none."""
    store = getattr(problem, "store", None)
    if store is None:
        return None
    if isinstance(store, (str, os.PathLike)):
        return Path(store)
    path = getattr(store, "path", None)
    return None if path is None else Path(path)


class PointLog:
    """Append-only record of the parameter vectors evaluated on one store.

    One JSON line per point, ``{"names": [...], "model": ..., "theta": [...]}``, written and
    flushed *before*
    the point is evaluated: a run killed at any moment leaves every point it asked for in the
    file (a torn last line is skipped on reading). Rerun through the store, a finished point
    costs no model call, and a point killed in flight is evaluated then. A point already in the
    file is not written again. Several processes may append to the same file.

    Args:
        path: the file, conventionally ``<store>.points.jsonl`` (see :func:`point_log_for`).
        names: the parameter names of the problem, which select the lines it can reuse.
        model: identity of the problem's forward model; only points of the same model are
            reused, since rerunning another model's points would cost new model runs.
    """

    def __init__(self, path: str | Path, names: list[str], model: str | None = None) -> None:
        self.path = Path(path)
        self.names = list(names)
        self.model = model
        self._seen: set[tuple[float, ...]] | None = None

    def append(self, theta: np.ndarray) -> None:
        """Append the points ``theta`` (`N x D`) that the file does not hold yet."""
        if self._seen is None:
            self.read()
        assert self._seen is not None
        lines = []
        for row in np.atleast_2d(theta):
            key = tuple(float(v) for v in row)
            if key not in self._seen:
                self._seen.add(key)
                item = {"names": self.names, "model": self.model, "theta": list(key)}
                lines.append(json.dumps(item) + "\n")
        if lines:
            with open(self.path, "a+b") as fh:
                if fh.tell() > 0:
                    fh.seek(-1, os.SEEK_END)
                    if fh.read(1) != b"\n":  # end a line torn by a killed process
                        lines.insert(0, "\n")
                fh.write("".join(lines).encode("utf-8"))
                fh.flush()

    def read(self) -> np.ndarray:
        """Distinct recorded points of problems with the same names and model, first seen first
        (`M x D`)."""
        rows: list[tuple[float, ...]] = []
        seen: set[tuple[float, ...]] = set()
        text = self.path.read_text(encoding="utf-8") if self.path.exists() else ""
        for line in text.splitlines():
            try:
                item = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line torn by a killed process
            if item.get("names") != self.names or item.get("model") != self.model:
                continue
            row = tuple(float(v) for v in item["theta"])
            if row not in seen:
                seen.add(row)
                rows.append(row)
        self._seen = seen
        return np.array(rows, dtype=np.float64).reshape(-1, len(self.names))


def point_log_for(problem: Problem) -> PointLog | None:
    """The :class:`PointLog` beside the problem's store, or None when it has no store."""
    path = store_path(problem)
    if path is None:
        return None
    model = model_identity(problem.model) if hasattr(problem, "model") else None
    return PointLog(path.with_name(path.name + ".points.jsonl"), list(problem.names), model)


class ModelRunsFailed(RuntimeError):
    """No evaluation so far gave a finite log joint and model runs failed: the inference cannot
    go on. The message is one line quoting the first model error (e.g. a wrong output shape)."""


@dataclass
class LogJointTarget:
    """Counted, recorded evaluations of ``problem.log_joint``.

    Attributes:
        problem: object with ``log_joint(theta) -> (...)`` for ``theta`` `... x D`.
        point_log: where evaluated points are recorded, or None.
        impute_failures: replace a non-finite value inside the hard bounds by the lowest finite
            value seen so far (for PyVBMC); otherwise return -inf (for emcee).
        hard_bounds: `D x 2` hard bounds (points on or outside them are outside the support).
        X, y: every evaluated point (`N x D`) and its log joint as returned by the problem.
        n_failed: evaluations inside the hard bounds whose log joint was not finite.
    """

    problem: Problem
    point_log: PointLog | None = None
    impute_failures: bool = False
    hard_bounds: np.ndarray | None = None
    X: list[np.ndarray] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    n_failed: int = 0
    first_error: str | None = None

    def evaluate(self, theta: np.ndarray) -> np.ndarray:
        """Log joint of a batch ``theta`` (`N x D`) -> `N`, with failures handled as above."""
        theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
        if self.point_log is not None:
            self.point_log.append(theta)
        raw = self._log_joint(theta)
        self.X.extend(theta)
        self.y.extend(raw.tolist())
        return self._clean(theta, raw)

    def _log_joint(self, theta: np.ndarray) -> np.ndarray:
        """``problem.log_joint`` of `N x D` points; a point whose evaluation raises gives NaN."""
        try:
            return np.asarray(self.problem.log_joint(theta), dtype=np.float64).reshape(-1)
        except Exception as exc:  # a model run that raised (no store to record it)
            if theta.shape[0] == 1:
                self.first_error = self.first_error or f"{type(exc).__name__}: {exc}"
                return np.full(1, np.nan)
            return np.concatenate([self._log_joint(row[None, :]) for row in theta])

    def __call__(self, theta: np.ndarray) -> float:
        """Log joint of one point (`D` or `1 x D`) as a float: PyVBMC's target."""
        return float(self.evaluate(np.reshape(theta, (1, -1)))[0])

    def _clean(self, theta: np.ndarray, raw: np.ndarray) -> np.ndarray:
        out = raw.copy()
        bad = ~np.isfinite(out)
        if self.hard_bounds is not None:
            lo, hi = self.hard_bounds[:, 0], self.hard_bounds[:, 1]
            inside = np.all((theta > lo) & (theta < hi), axis=1)
            bad &= inside
        self.n_failed += int(bad.sum())
        out[np.isnan(out)] = -np.inf
        if bad.any() and not np.isfinite(np.asarray(self.y, dtype=np.float64)).any():
            raise ModelRunsFailed(
                f"the log joint is not finite at any point evaluated so far ({self.n_failed} "
                f"failed model runs of {len(self.y)} points); first error: {self.error_text()}"
            )
        if self.impute_failures and bad.any():
            finite = np.asarray(self.y, dtype=np.float64)
            out[bad] = finite[np.isfinite(finite)].min()
        return out

    def error_text(self) -> str:
        """First line of the first model error known (caught here or recorded by the problem's
        cache or store), or a sentence saying that none was recorded."""
        error = self.first_error
        failures = getattr(self.problem, "failures", None)
        if error is None and callable(failures):
            try:
                errors = failures()[1]
            except Exception:  # noqa: BLE001 - a damaged store must not hide the run's own error
                errors = []
            error = errors[0] if errors else None
        if error is None:
            return "no model error was recorded (the log joint itself is not finite)"
        lines = str(error).strip().splitlines()
        line = lines[0] if lines else str(error)
        return line if len(line) <= 300 else line[:297] + "..."

    def known(self) -> tuple[np.ndarray, np.ndarray]:
        """Distinct evaluated points with a finite log joint: (`M x D`, `M`), best first."""
        if not self.X:
            return np.zeros((0, 0)), np.zeros(0)
        X = np.array(self.X)
        y = np.array(self.y)
        ok = np.isfinite(y)
        X, y = X[ok], y[ok]
        _, first = np.unique(X, axis=0, return_index=True)
        X, y = X[np.sort(first)], y[np.sort(first)]
        order = np.argsort(-y, kind="stable")
        return X[order], y[order]
