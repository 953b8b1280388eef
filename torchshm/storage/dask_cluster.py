"""Dask ``distributed`` clients for :func:`evaluate`: a local cluster, a running one, or a queue.

Dask schedules the model runs; this module only builds a client from plain settings (as
written in ``conf/executor/dask.yaml``), so that every worker runs one model run at a time with
``cores_per_run`` cores:

* no address, no queue: a ``LocalCluster`` of worker processes on this machine, one thread
  each, ``n_workers x cores_per_run`` at most the machine's cores;
* ``address``: the scheduler of a cluster started elsewhere (``dask scheduler`` and
  ``dask worker --nthreads 1`` on the nodes);
* ``jobqueue``: a ``dask-jobqueue`` cluster whose batch jobs (Slurm, PBS, SGE, LSF, ...) are
  one worker each, with ``cores_per_run`` cores and one thread.
"""

from __future__ import annotations

import socket
from typing import Any

from torchshm.forward.cores import available_cores, check_cores_per_run, fit_workers

#: ``jobqueue`` names and their dask-jobqueue classes
JOBQUEUE_CLASSES = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster",
                    "lsf": "LSFCluster", "htcondor": "HTCondorCluster", "oar": "OARCluster",
                    "moab": "MoabCluster"}


def jobqueue_cluster(jobqueue: str, cores_per_run: int = 1, **params: Any) -> Any:
    """A dask-jobqueue cluster whose every job is one single-threaded worker of ``cores_per_run`` cores.

    Args:
        jobqueue: ``"slurm"``, ``"pbs"``, ``"sge"``, ``"lsf"``, ``"htcondor"``, ``"oar"`` or ``"moab"``.
        cores_per_run: cores of each job (the run's threads).
        **params: the cluster class's options: ``memory`` (required, e.g. ``"16GB"``),
            ``queue``, ``account``, ``walltime``, ``job_extra_directives``, ``job_script_prologue``
            (e.g. ``["module load calculix"]``), ``log_directory``, ...

    Raises:
        ValueError: for an unknown queue or a bad option (the message names it).
    """
    import dask_jobqueue

    if jobqueue not in JOBQUEUE_CLASSES:
        raise ValueError(f"unknown jobqueue {jobqueue!r}; expected one of {tuple(JOBQUEUE_CLASSES)}")
    cls = getattr(dask_jobqueue, JOBQUEUE_CLASSES[jobqueue])
    # the job books cores_per_run cores; its worker runs one task at a time (the last
    # --nthreads of the worker's command line is the one it uses)
    extra = [*params.pop("worker_extra_args", []), "--nthreads", "1"]
    try:
        return cls(cores=check_cores_per_run(cores_per_run), processes=1, worker_extra_args=extra, **params)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bad {jobqueue} jobqueue option: {str(exc).splitlines()[0]}") from None


def dask_client(address: str | None = None, n_workers: int = -1, cores_per_run: int = 1,
                jobqueue: str | None = None, **params: Any) -> Any:
    """A ``distributed.Client`` for :func:`torchshm.storage.evaluate` (its ``executor``).

    Args:
        address: a running scheduler, e.g. ``"tcp://10.0.0.5:8786"``; None: start a cluster.
        n_workers: workers of the started cluster (-1: as many as fit this machine for a
            ``LocalCluster``; the number of batch jobs with ``jobqueue``, then required).
        cores_per_run: cores (threads) of one model run.
        jobqueue: start a dask-jobqueue cluster (see :func:`jobqueue_cluster`) instead of a
            ``LocalCluster``.
        **params: options of ``LocalCluster`` (e.g. ``memory_limit``, ``dashboard_address``)
            or of the jobqueue class.

    Returns:
        The client; :func:`close_client` closes it and the cluster it started.

    Raises:
        ValueError: when the local workers need more cores than the machine has, for
            ``n_workers`` < 1 with a queue, or for a bad option.
    """
    import distributed

    cores_per_run = check_cores_per_run(cores_per_run)
    if address is not None:
        return distributed.Client(address)
    if jobqueue is not None:
        if n_workers < 1:
            raise ValueError(f"n_workers (batch jobs) must be at least 1 with jobqueue, got {n_workers}")
        cluster = jobqueue_cluster(jobqueue, cores_per_run, **params)
        cluster.scale(n_workers)
        return distributed.Client(cluster)
    n_workers = fit_workers(n_workers, cores_per_run)
    params.setdefault("dashboard_address", ":0")  # a free port: two studies side by side
    try:
        cluster = distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, **params)
    except TypeError as exc:
        raise ValueError(f"bad LocalCluster option: {exc}") from None
    return distributed.Client(cluster)


def close_client(client: Any) -> None:
    """Close ``client`` and the cluster it was started with (not a cluster it connected to)."""
    cluster = getattr(client, "cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def check_client_cores(client: Any, cores_per_run: int) -> None:
    """Refuse ``cores_per_run`` when the client's workers on this machine would need more
    cores than it has (threads of local workers x ``cores_per_run``).

    Workers on other machines are not checked: give them ``--nthreads 1`` and as many cores as
    ``cores_per_run`` (a jobqueue cluster of :func:`dask_client` does).
    """
    local = {"127.0.0.1", "localhost", "::1", socket.gethostname()}
    try:
        local.add(socket.gethostbyname(socket.gethostname()))
    except OSError:
        pass
    workers = client.scheduler_info(n_workers=-1).get("workers", {}).values()
    threads = sum(int(w.get("nthreads", 1)) for w in workers if w.get("host") in local)
    if threads * cores_per_run > available_cores():
        raise ValueError(
            f"the Dask workers on this machine run {threads} threads x cores_per_run="
            f"{cores_per_run}, more than its {available_cores()} cores; start fewer workers or "
            f"threads, or lower cores_per_run"
        )


__all__ = ["JOBQUEUE_CLASSES", "check_client_cores", "close_client", "dask_client", "jobqueue_cluster"]
