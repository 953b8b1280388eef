"""A forward model whose batch of θp runs in parallel (joblib processes or submitit jobs).

Inference calls a forward model with a batch of parameter vectors (emcee: every walker of a
step at once). :class:`ParallelModel` hands such a batch to :func:`torchshm.storage.evaluate`,
which spreads the distinct θp over local processes or cluster jobs, and returns the strains in
the batch's order. Its identity is the wrapped model's, so an evaluation store holds the same
entries with and without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor, model_identity

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel


class ParallelModel:
    """Wrap a forward model so that each call evaluates its rows in parallel.

    Args:
        model: a picklable forward model (``model(theta_p) -> ... x L x n``, ``x``, ``loads``).
        n_jobs: local worker processes (joblib); -1 uses every core. Ignored with ``executor``.
        executor: a submitit executor (:func:`torchshm.storage.make_executor`), one job per θp.

    Attributes:
        x, loads, names: those of ``model`` (``names`` only when it declares them).
        identity: ``model``'s identity in an evaluation store.
    """

    def __init__(self, model: ForwardModel, n_jobs: int = 1, executor: Any | None = None) -> None:
        self.model = model
        self.n_jobs, self.executor = n_jobs, executor
        self.x, self.loads = model.x, model.loads
        self.identity = model_identity(model)
        if getattr(model, "names", None) is not None:
            self.names = model.names

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L x n` [µε] for `... x P`; NaN rows where a run failed."""
        from torchshm.storage import evaluate

        theta = as_tensor(theta_p).detach()
        flat = theta.reshape(-1, theta.shape[-1]).numpy()
        res = evaluate(self.model, flat, n_jobs=self.n_jobs, executor=self.executor)
        out = torch.as_tensor(np.asarray(res.outputs, dtype=np.float64))
        return out.reshape(*theta.shape[:-1], *out.shape[1:])

    def __repr__(self) -> str:
        where = "submitit" if self.executor is not None else f"n_jobs={self.n_jobs}"
        return f"ParallelModel({self.model!r}, {where})"


__all__ = ["ParallelModel"]
