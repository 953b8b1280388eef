"""A forward model whose batch of θp runs in parallel (joblib processes, Dask, any executor).

Inference calls a forward model with a batch of parameter vectors (emcee: every walker of a
step at once). :class:`ParallelModel` hands such a batch to :func:`~torchshm.storage.evaluate`,
which spreads the distinct θp over local processes or cluster jobs, and returns the strains in
the batch's order. Its identity is the wrapped model's, so an evaluation store holds the same
entries with and without it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.cores import CoresPerRun
from torchshm.forward.protocol import as_tensor, model_identity
from torchshm.storage.evaluate import evaluate, plan_cores
from torchshm.storage.futures import check_executor, is_dask_client

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel


class ParallelModel:
    """Wrap a forward model so that each call evaluates its rows in parallel.

    Args:
        model: a picklable forward model (``model(theta_p) -> ... x L x n``, ``x``, ``loads``).
        n_jobs: local worker processes (joblib); -1 uses every core (with ``cores_per_run``:
            as many workers as fit). Ignored with ``executor``.
        executor: any executor whose ``submit`` returns futures (a ``dask.distributed.Client``,
            :func:`torchshm.storage.dask_client`), or a submitit executor
            (:func:`torchshm.storage.make_executor`); one task or job per θp.
        cores_per_run: threads of one run (``OMP_NUM_THREADS``, ...); None: as they are.
        cores_env: the program's own thread variables, set to ``cores_per_run`` too.

    Attributes:
        x, loads, names, default_priors: those of ``model`` (``names`` and ``default_priors``
            only when it declares them).
        identity: ``model``'s identity in an evaluation store.
        model: the model as the workers run it (wrapped in
            :class:`~torchshm.forward.cores.CoresPerRun` when ``cores_per_run`` is given).

    Raises:
        ValueError: when local workers x ``cores_per_run`` exceed the machine's cores, or
            ``executor`` has no ``submit``; nothing has run.
    """

    def __init__(self, model: ForwardModel, n_jobs: int = 1, executor: Any | None = None,
                 cores_per_run: int | None = None, cores_env: Sequence[str] = ()) -> None:
        if executor is not None:
            check_executor(executor)
        if cores_per_run is not None:
            n_jobs = plan_cores(n_jobs, executor, cores_per_run)
            model = CoresPerRun(model, cores_per_run, cores_env)
        self.model = model
        self.n_jobs, self.executor, self.cores_per_run = n_jobs, executor, cores_per_run
        self.x, self.loads = model.x, model.loads
        self.identity = model_identity(model)
        if getattr(model, "names", None) is not None:
            self.names = model.names
        if getattr(model, "default_priors", None) is not None:
            self.default_priors = model.default_priors

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L x n` [µε] for `... x P`; NaN rows where a run failed."""
        theta = as_tensor(theta_p).detach()
        flat = theta.reshape(-1, theta.shape[-1]).numpy()
        res = evaluate(self.model, flat, n_jobs=self.n_jobs, executor=self.executor)
        out = torch.as_tensor(np.asarray(res.outputs, dtype=np.float64))
        return out.reshape(*theta.shape[:-1], *out.shape[1:])

    def close(self) -> None:
        """Close a Dask client made by :func:`torchshm.storage.dask_client` (and its cluster)."""
        if is_dask_client(self.executor):
            from torchshm.storage.dask_cluster import close_client

            close_client(self.executor)

    @property
    def parallel_plan(self) -> tuple[Any, int, Any]:
        """``(model, n_jobs, executor)``: how :func:`~torchshm.storage.evaluate` runs a design
        given this wrapper (its model, with its parallelism)."""
        return self.model, self.n_jobs, self.executor

    def __repr__(self) -> str:
        where = type(self.executor).__name__ if self.executor is not None else f"n_jobs={self.n_jobs}"
        return f"ParallelModel({self.model!r}, {where})"


__all__ = ["ParallelModel"]
