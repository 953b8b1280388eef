"""Executors for :func:`evaluate`: submitit for local and Slurm jobs, joblib for processes, Dask.

Scheduling is not done here: submitit submits one job per θp (a Slurm job array), joblib
spreads the runs over local processes, Dask over its workers (:mod:`.dask_cluster`). This
module only builds them from plain settings, as written in ``conf/executor/*.yaml``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import submitit

#: kinds accepted by :func:`make_executor`
EXECUTOR_KINDS = ("local", "slurm", "debug")
#: kinds accepted by :func:`evaluation_options`
EVALUATION_KINDS = ("serial", "joblib", "dask", *EXECUTOR_KINDS)

# A finite element run takes about 10 minutes; submitit's own local default is 2.
_DEFAULTS: dict[str, dict[str, Any]] = {
    "local": {"timeout_min": 60},
    "slurm": {"timeout_min": 60, "cpus_per_task": 1, "mem_gb": 4.0,
              "slurm_array_parallelism": 32},
    "debug": {},
}


def make_executor(kind: str, folder: str | Path, **params: Any) -> submitit.Executor:
    """A submitit executor that runs one forward-model evaluation per job.

    Args:
        kind: ``"slurm"`` (a Slurm cluster), ``"local"`` (one local process per job, all
            started at once) or ``"debug"`` (in this process, when a result is asked for).
        folder: where submitit keeps job scripts, pickles and logs (``%j`` is the job id).
        **params: submitit parameters, e.g. ``timeout_min`` (per job, minutes),
            ``cpus_per_task``, ``mem_gb``, ``slurm_partition``, ``slurm_array_parallelism``
            (jobs of the array running at once), ``slurm_additional_parameters``.

    Returns:
        A ``submitit.AutoExecutor``.

    Raises:
        ValueError: for an unknown kind or parameter (the message names it), or for
            ``"slurm"`` on a machine without Slurm.
    """
    if kind not in EXECUTOR_KINDS:
        raise ValueError(f"unknown executor kind {kind!r}; expected one of {EXECUTOR_KINDS}")
    try:
        executor = submitit.AutoExecutor(folder=str(folder), cluster=kind)
    except RuntimeError as exc:  # e.g. no ``srun`` on this machine
        raise ValueError(f"cannot make a {kind} executor here: {exc}") from None
    try:
        executor.update_parameters(**{**_DEFAULTS[kind], **params})
    except (NameError, AssertionError, ValueError, TypeError) as exc:
        lines = str(exc).strip().splitlines()
        raise ValueError(f"bad {kind} executor parameter: {lines[0] if lines else exc}") from None
    return executor


def evaluation_options(
    kind: str = "serial",
    folder: str | Path = "runs/submitit",
    n_jobs: int = 1,
    params: Mapping[str, Any] | None = None,
    address: str | None = None,
    jobqueue: str | None = None,
    cores_per_run: int | None = None,
    cores_env: Sequence[str] = (),
) -> dict[str, Any]:
    """Keyword arguments ``n_jobs``, ``executor``, ``cores_per_run`` and ``cores_env`` for
    :func:`evaluate` (and :class:`~torchshm.storage.ParallelModel`) from plain settings.

    Args:
        kind: ``"serial"`` (in this process), ``"joblib"`` (``n_jobs`` local processes),
            ``"dask"`` (a Dask client, :func:`~torchshm.storage.dask_client`), or a submitit
            kind of :func:`make_executor`.
        folder: submitit's folder (submitit kinds only).
        n_jobs: local worker processes (``"joblib"``), or Dask workers (``"dask"`` without
            ``address``: local workers, -1 as many as fit; with ``jobqueue``: batch jobs).
        params: submitit parameters, or options of the Dask cluster (``LocalCluster`` or the
            jobqueue class).
        address: ``"dask"``: a running scheduler's address; None starts a cluster.
        jobqueue: ``"dask"``: ``"slurm"``, ``"pbs"``, ``"sge"``, ``"lsf"``, ... (dask-jobqueue).
        cores_per_run: threads of one run; None leaves them as they are (``"dask"``: 1).
        cores_env: the program's own thread variables, set to ``cores_per_run`` too.

    Returns:
        ``{"n_jobs": int, "executor": executor or None, "cores_per_run": int or None,
        "cores_env": list}``.

    Raises:
        ValueError: for an unknown kind or parameter, or runs that do not fit the machine.
    """
    if kind not in EVALUATION_KINDS:
        raise ValueError(f"unknown executor kind {kind!r}; expected one of {EVALUATION_KINDS}")
    if kind != "dask" and (address is not None or jobqueue is not None):
        raise ValueError(f"address and jobqueue apply to executor kind 'dask', not {kind!r}")
    options: dict[str, Any] = {"n_jobs": 1, "executor": None, "cores_per_run": cores_per_run,
                               "cores_env": list(cores_env)}
    if kind == "joblib":
        options["n_jobs"] = int(n_jobs)
    elif kind == "dask":
        from torchshm.storage.dask_cluster import dask_client

        options["cores_per_run"] = 1 if cores_per_run is None else cores_per_run
        options["executor"] = dask_client(address, int(n_jobs), options["cores_per_run"], jobqueue,
                                          **dict(params or {}))
    elif kind != "serial":
        options["executor"] = make_executor(kind, folder, **dict(params or {}))
    return options
