"""A forward model evaluated once per distinct parameter vector.

Outputs are cached in process under the parameter vector's canonical key (12 significant
digits, as in the evaluation store). With a store, missing outputs are requested through
:func:`torchshm.storage.evaluate`, which persists every run and reuses stored ones.
"""

from __future__ import annotations

import math
from os import PathLike
from typing import Any

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels.base import as_float64
from torchshm.likelihood.parameters import canonical_key

Key = tuple[float, ...]


class CachedModel:
    """Wraps a forward model so that no parameter vector is evaluated twice.

    Args:
        model: forward model ``model(theta_p `... x P`) -> `... x L_model x n_model``` [µε]
            with attributes ``x`` and ``loads``.
        store: path of an evaluation store, an ``EvaluationStore``, or ``None``.

    Attributes:
        n_evaluations: model calls made through this object (cache and store hits excluded).
        store: the ``EvaluationStore`` or ``None``.
    """

    def __init__(self, model: Any, store: str | PathLike[str] | Any | None = None) -> None:
        self.model = model
        self.shape = (as_numpy(model.loads).size, as_numpy(model.x).size)
        self.store = _open_store(store)
        self.n_evaluations = 0
        self._cache: dict[Key, Tensor] = {}

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L_model x n_model` [µε] (NaN where a run failed) for `... x P`.

        Each distinct vector is evaluated at most once per call and once per object (once per
        store with a store). A tensor that requires grad is sent to the model on every call so
        that the result keeps its graph (cached outputs carry none), unless a store is used:
        stored outputs are never differentiable.
        """
        tp = as_float64(theta_p)
        flat = tp.reshape(-1, tp.shape[-1])
        keys = [canonical_key(row) for row in flat.detach().cpu().numpy()]
        unique, first, inverse = _dedupe(keys)
        if flat.requires_grad and self.store is None:
            out = self._call_model(flat[first])
            self._cache.update((k, o.detach()) for k, o in zip(unique, out, strict=True))
        else:
            todo = [i for i, k in zip(first, unique, strict=True) if k not in self._cache]
            if todo:
                self._evaluate(flat[todo].detach(), [keys[i] for i in todo])
            failed = torch.full(self.shape, math.nan, dtype=torch.float64)
            out = torch.stack([self._cache.get(k, failed) for k in unique])
        return out[inverse].reshape(*tp.shape[:-1], *self.shape)

    def evaluations(self, n_params: int) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_p `M x P`, outputs `M x L_model x n_model`)`` of every finished evaluation
        made through this object or found in its store (failed runs excluded)."""
        if self.store is not None:
            theta_p, outputs = self.store.all(self.model)
            outputs = np.asarray(outputs, dtype=np.float64)
        else:
            done = {k: o for k, o in self._cache.items() if bool(torch.isfinite(o).all())}
            theta_p = list(done)
            outputs = np.stack([o.numpy() for o in done.values()]) if done else None
        if outputs is None:
            outputs = np.empty((0, *self.shape))
        return np.asarray(theta_p, dtype=np.float64).reshape(len(outputs), n_params), outputs

    def _call_model(self, rows: Tensor) -> Tensor:
        """Model outputs of rows `U x P`, counted and shape-checked."""
        self.n_evaluations += rows.shape[0]
        out = as_float64(self.model(rows))
        if tuple(out.shape) != (rows.shape[0], *self.shape):
            raise ValueError(
                f"the model returned shape {tuple(out.shape)}, "
                f"expected {(rows.shape[0], *self.shape)}"
            )
        return out

    def _evaluate(self, rows: Tensor, keys: list[Key]) -> None:
        """Evaluate rows `U x P` (directly or through the store); cache the finished ones."""
        if self.store is None:
            with torch.no_grad():
                outputs = self._call_model(rows)
            self._cache.update((k, o.detach()) for k, o in zip(keys, outputs, strict=True))
            return
        from torchshm.storage import evaluate

        res = evaluate(self.model, rows.numpy(), store=self.store)
        self.n_evaluations += int(res.n_new)
        outputs = torch.as_tensor(np.asarray(res.outputs, dtype=np.float64))
        self._cache.update((k, o) for k, o, ok in zip(keys, outputs, res.ok, strict=True) if ok)


def _dedupe(keys: list[Key]) -> tuple[list[Key], list[int], Tensor]:
    """Distinct keys (first-seen order), the row of each one's first occurrence, and for every
    row the position of its key among the distinct ones."""
    slot: dict[Key, int] = {}
    first: list[int] = []
    for i, key in enumerate(keys):
        if key not in slot:
            slot[key] = len(first)
            first.append(i)
    return list(slot), first, torch.as_tensor([slot[k] for k in keys], dtype=torch.long)


def as_numpy(values: object) -> np.ndarray:
    """Float64 numpy copy of an array-like or tensor."""
    if isinstance(values, Tensor):
        return values.detach().cpu().numpy().astype(np.float64)
    return np.asarray(values, dtype=np.float64)


def _open_store(store: object) -> Any:
    """An ``EvaluationStore`` for a path; anything else is returned as it is."""
    if store is None or not isinstance(store, (str, PathLike)):
        return store
    from torchshm.storage import EvaluationStore

    return EvaluationStore(store)
