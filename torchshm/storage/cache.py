"""Where a problem's model outputs are kept: one interface, two backends.

In the manner of emcee's ``Backend`` and ``HDFBackend``, :class:`MemoryBackend` keeps the
evaluations of a forward model in this process and :class:`StoreBackend` keeps them in an
:class:`~torchshm.storage.EvaluationStore` (a SQLite file, durable across runs); both have
the same methods. :func:`open_backend` picks one from what the user passed (``None``, a path or a
store). Evaluations are keyed by :func:`~torchshm.storage.keys.theta_key` (12 significant
digits) in both. A failing run is recorded with its error text, never raised.
"""

from __future__ import annotations

from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor
from torchshm.storage.evaluate import evaluate
from torchshm.storage.keys import key_theta
from torchshm.storage.record import check_dtype, check_outputs, error_text
from torchshm.storage.store import EvaluationStore

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel


class MemoryBackend:
    """Evaluations kept in this process (lost when it ends).

    The model is called once with the whole batch of missing vectors; if that call raises or
    returns a wrong shape, each vector is run on its own so that one failing vector does not
    fail the others, and each failure is recorded with its error text.

    Attributes:
        store: always None (no evaluation store).
        differentiable: True: a caller may send a tensor that requires grad to the model.
    """

    store: EvaluationStore | None = None
    differentiable = True

    def __init__(self) -> None:
        self._outputs: dict[str, Tensor] = {}
        self._errors: dict[str, str] = {}

    def get(self, keys: list[str]) -> tuple[dict[str, Tensor], set[str]]:
        """Finished outputs ``key -> L x n`` [µε] and the keys whose run failed."""
        found = {k: self._outputs[k] for k in keys if k in self._outputs}
        return found, {k for k in keys if k in self._errors}

    def put(self, key: str, output: Tensor) -> None:
        """Keep one finished output `L x n` (computed by the caller, e.g. with a gradient)."""
        self._outputs[key] = output.detach()

    def evaluate(
        self, model: ForwardModel, rows: Tensor, keys: list[str], shape: tuple[int, int]
    ) -> int:
        """Run the model for parameter vectors ``rows`` (`U x P`, keys ``keys``) and keep the
        outcomes. Returns the number of model calls (vectors sent to the model)."""
        try:
            with torch.no_grad():
                raw = model(rows)
            check_dtype(raw)
            out = as_tensor(raw)
            if tuple(out.shape) != (rows.shape[0], *shape):
                if out.ndim == len(shape) + 1 and out.shape[0] == rows.shape[0]:
                    raise ValueError(f"model output has shape {tuple(out.shape[1:])} per parameter "
                                     f"vector, expected (L, n) = {shape}")
                raise ValueError(
                    f"model output has shape {tuple(out.shape)} for {rows.shape[0]} parameter "
                    f"vector(s), expected {(rows.shape[0], *shape)}"
                )
        except Exception as exc:  # record it; with several vectors, find which ones fail
            if rows.shape[0] == 1:
                self._errors[keys[0]] = error_text(exc)
                return 1
            for i, key in enumerate(keys):
                self._run_one(model, rows[i : i + 1], key, shape)
            return 2 * rows.shape[0]
        for key, row in zip(keys, out, strict=True):
            self._keep(key, lambda row=row: check_outputs(row, shape))
        return rows.shape[0]

    def _run_one(self, model: ForwardModel, row: Tensor, key: str, shape: tuple[int, int]) -> None:
        """Run one vector `1 x P` and keep its output or its error text."""

        def run() -> np.ndarray:
            with torch.no_grad():
                return check_outputs(model(row), shape)

        self._keep(key, run)

    def _keep(self, key: str, run: Any) -> None:
        """Keep the output `L x n` that ``run()`` returns, or the error text of what it raises."""
        try:
            self._outputs[key] = torch.as_tensor(run())
        except Exception as exc:  # a failing model run is data, not a crash
            self._errors[key] = error_text(exc)

    def all(self, model: ForwardModel, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_p `M x P`, outputs `M x L x n`)`` of every finished evaluation."""
        if not self._outputs:
            return np.empty((0, 0)), np.empty((0, *shape))
        theta = np.stack([key_theta(k) for k in self._outputs])
        return theta, np.stack([o.numpy() for o in self._outputs.values()]).astype(np.float64)

    def failures(self, model: ForwardModel) -> tuple[np.ndarray, list[str]]:
        """Failed evaluations: parameters `F x P` and their error texts, oldest first."""
        if not self._errors:
            return np.empty((0, 0)), []
        return np.stack([key_theta(k) for k in self._errors]), list(self._errors.values())


class StoreBackend(MemoryBackend):
    """Evaluations kept in an :class:`EvaluationStore` (and, read once, in this process).

    Every missing vector goes through :func:`torchshm.storage.evaluate`: one model call per
    vector, each result committed as soon as it exists, finished runs of earlier processes
    reused. Stored outputs are never differentiable.

    Args:
        store: the store, or the path of its SQLite file.
    """

    differentiable = False

    def __init__(self, store: EvaluationStore | str | PathLike[str]) -> None:
        super().__init__()
        self.store = store if isinstance(store, EvaluationStore) else EvaluationStore(store)

    def evaluate(
        self, model: ForwardModel, rows: Tensor, keys: list[str], shape: tuple[int, int]
    ) -> int:
        """As :meth:`MemoryBackend.evaluate`, through the store (failed runs are not cached in
        this process, so a later call asks the store again)."""
        res = evaluate(model, rows.detach().cpu().numpy(), store=self.store)
        outputs = torch.as_tensor(np.asarray(res.outputs, dtype=np.float64))
        for key, out, ok, error in zip(keys, outputs, res.ok, res.errors, strict=True):
            if ok:
                self._outputs[key] = out
            else:
                self._errors[key] = str(error)
        return int(res.n_new)

    def get(self, keys: list[str]) -> tuple[dict[str, Tensor], set[str]]:
        """Outputs read before in this process; failures are asked for again (see above)."""
        return {k: self._outputs[k] for k in keys if k in self._outputs}, set()

    def all(self, model: ForwardModel, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Every finished evaluation of ``model`` in the store (other processes' included)."""
        assert self.store is not None
        theta, outputs = self.store.all(model)
        return theta, np.asarray(outputs, dtype=np.float64).reshape(-1, *shape)

    def failures(self, model: ForwardModel) -> tuple[np.ndarray, list[str]]:
        """Failed evaluations of ``model`` in the store, oldest first."""
        assert self.store is not None
        return self.store.failures(model)


def open_backend(store: object) -> MemoryBackend:
    """The backend for a ``store`` argument: None -> :class:`MemoryBackend`; a path or an
    :class:`EvaluationStore` -> :class:`StoreBackend`; a backend is returned as it is.

    Raises:
        TypeError: for anything else, naming its type.
    """
    if store is None:
        return MemoryBackend()
    if isinstance(store, MemoryBackend):
        return store
    if isinstance(store, (str, PathLike, EvaluationStore)):
        return StoreBackend(store)
    raise TypeError(
        f"store must be None, a path or an EvaluationStore, got {type(store).__name__}"
    )
