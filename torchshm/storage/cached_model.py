"""A forward model evaluated once per distinct parameter vector, through a cache backend.

:class:`CachedModel` is what a :class:`~torchshm.Problem` calls for model outputs. Vectors that
agree to 12 significant digits (:func:`~torchshm.storage.keys.canonical_theta`) are one
evaluation; where the outputs are kept is the backend's business (:mod:`.cache`: in this process,
or in an evaluation store). A failed run gives NaN outputs and its error text is kept
(:meth:`CachedModel.failures`); the model's exception never reaches the caller.
"""

from __future__ import annotations

import math
import os
import socket
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor, model_identity, output_shape
from torchshm.storage.cache import MemoryBackend, open_backend
from torchshm.storage.keys import canonical_theta, theta_key
from torchshm.storage.record import Record, check_dtype, now_utc
from torchshm.storage.store import EvaluationStore

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel


class CachedModel:
    """Wraps a forward model so that no parameter vector is evaluated twice.

    Args:
        model: forward model ``model(theta_p `... x P`) -> `... x L_model x n_model``` [µε]
            with attributes ``x`` and ``loads``.
        store: None (outputs kept in this process), the path of an evaluation store, an
            :class:`~torchshm.storage.EvaluationStore`, or a backend of :mod:`.cache`.

    Attributes:
        n_evaluations: model calls made through this object (cache and store hits excluded).
        backend: where outputs are kept (:class:`~torchshm.storage.cache.MemoryBackend` or
            :class:`~torchshm.storage.cache.StoreBackend`).
    """

    def __init__(
        self, model: ForwardModel, store: str | PathLike[str] | EvaluationStore | MemoryBackend | None = None
    ) -> None:
        self.model = model
        self.shape = output_shape(model)
        self.backend = open_backend(store)
        self.n_evaluations = 0

    @property
    def store(self) -> EvaluationStore | None:
        """The evaluation store behind the backend, or None."""
        return self.backend.store

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L_model x n_model` [µε] (NaN where a run failed) for `... x P`.

        Each distinct vector is evaluated at most once. A tensor that requires grad is sent to
        the model on every call, so that the result keeps its graph, when the backend allows it
        (in memory); stored outputs are never differentiable. A non-finite vector is not sent to
        the model: its outputs are NaN.
        """
        tp = as_tensor(theta_p)
        flat = tp.reshape(-1, tp.shape[-1])
        finite = torch.isfinite(flat).all(-1)
        keys = [theta_key(row) for row in canonical_theta(flat[finite].detach().cpu().numpy())] \
            if bool(finite.any()) else []
        keys_iter = iter(keys)
        all_keys = [next(keys_iter) if ok else "" for ok in finite.tolist()]
        unique = list(dict.fromkeys(k for k in all_keys if k))
        first: dict[str, int] = {}
        for i, k in enumerate(all_keys):
            if k:
                first.setdefault(k, i)
        if flat.requires_grad and self.backend.differentiable and unique:
            out = self._differentiable(flat, unique, first)
            if out is not None:
                return out[_inverse(all_keys, unique)].reshape(*tp.shape[:-1], *self.shape)
        found, failed = self.backend.get(unique)
        todo = [k for k in unique if k not in found and k not in failed]
        if todo:
            rows = torch.stack([flat[first[k]].detach() for k in todo])
            self.n_evaluations += self.backend.evaluate(self.model, rows, todo, self.shape)
            found, _ = self.backend.get(unique)
        nan = torch.full(self.shape, math.nan, dtype=torch.float64)
        out = torch.stack([found.get(k, nan) for k in unique] + [nan])
        return out[_inverse(all_keys, unique)].reshape(*tp.shape[:-1], *self.shape)

    def _differentiable(self, flat: Tensor, unique: list[str], first: dict[str, int]) -> Tensor | None:
        """Outputs `U x L x n` with their graph, or None when the model call fails (the
        vectors then go through the backend, which records the failure)."""
        rows = flat[[first[k] for k in unique]]
        try:
            raw = self.model(rows)
            check_dtype(raw)
            out = as_tensor(raw)
        except Exception:  # recorded by the backend on the no-grad path
            return None
        self.n_evaluations += rows.shape[0]
        if tuple(out.shape) != (rows.shape[0], *self.shape):
            return None
        for key, row in zip(unique, out, strict=True):
            if bool(torch.isfinite(row).all()):
                self.backend.put(key, row)
        nan = torch.full((1, *self.shape), math.nan, dtype=torch.float64)
        return torch.cat([out, nan])

    def attach_store(self, store: str | PathLike[str] | EvaluationStore) -> EvaluationStore:
        """Keep every later evaluation in ``store``, and copy there the finished runs kept in
        this process so far (none is run again). Returns the store.

        Raises:
            ValueError: when the outputs already go to a store.
        """
        if self.store is not None:
            raise ValueError(f"the evaluations already go to the store {self.store.path}")
        theta, outputs = self.backend.all(self.model, self.shape)
        self.backend = open_backend(store)
        identity = model_identity(self.model)
        keys = [theta_key(row) for row in canonical_theta(theta)] if len(outputs) else []
        for key, output in zip(keys, outputs, strict=True):
            self.store.put(Record(model=identity, key=key, status="ok",
                                  outputs=np.asarray(output, dtype=np.float64), error=None,
                                  wall_time=math.nan, finished_at=now_utc(),
                                  host=socket.gethostname(), pid=os.getpid()))
        return self.store

    def evaluations(self, n_params: int) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_p `M x P`, outputs `M x L_model x n_model`)`` of every finished evaluation
        made through this object or found in its store (failed runs excluded)."""
        theta, outputs = self.backend.all(self.model, self.shape)
        return np.asarray(theta, dtype=np.float64).reshape(len(outputs), n_params), outputs

    def failures(self) -> tuple[np.ndarray, list[str]]:
        """Failed evaluations: parameters `F x P` and their error texts, oldest first."""
        return self.backend.failures(self.model)


def _inverse(keys: list[str], unique: list[str]) -> Tensor:
    """For every row, its key's position in ``unique`` (``len(unique)`` for a non-finite row)."""
    slot = {k: i for i, k in enumerate(unique)}
    return torch.as_tensor([slot.get(k, len(unique)) for k in keys], dtype=torch.long)
