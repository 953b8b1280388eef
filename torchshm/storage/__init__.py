"""Durable evaluation store and parallel evaluation of forward models on designs.

Every forward-model evaluation is written to an :class:`EvaluationStore` (a SQLite file) as
soon as it finishes, so an interrupted study resumes without repeating a finished run, and a
failing run is recorded instead of ending the study. :func:`evaluate` runs a batch of
parameter vectors in process, in local processes (joblib), on any executor with ``submit``
(a Dask client, :func:`dask_client`) or as submitit jobs (Slurm).
"""

from __future__ import annotations

from torchshm.storage.cache import MemoryBackend, StoreBackend, open_backend
from torchshm.storage.cached_model import CachedModel
from torchshm.storage.evaluate import EvaluationResult, evaluate
from torchshm.storage.dask_cluster import close_client, dask_client
from torchshm.storage.executors import evaluation_options, make_executor
from torchshm.storage.keys import canonical_theta, theta_key
from torchshm.storage.parallel import ParallelModel
from torchshm.storage.record import Record
from torchshm.storage.store import EvaluationStore

__all__ = [
    "CachedModel",
    "EvaluationResult",
    "EvaluationStore",
    "Record",
    "canonical_theta",
    "close_client",
    "dask_client",
    "evaluate",
    "evaluation_options",
    "MemoryBackend",
    "ParallelModel",
    "StoreBackend",
    "open_backend",
    "make_executor",
    "theta_key",
]
