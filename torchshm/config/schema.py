"""Structured-config schemas of the ``torchshm-identify`` application.

Each dataclass types one node of ``conf/config.yaml``; Hydra validates the YAML files and every
command-line override against them (a misspelt key or a string where a number belongs is
reported before anything runs). The defaults below mirror the YAML files in ``conf/`` so that
the schema alone documents each option; the YAML files are what users read and edit.

Layout of the composed config::

    kernel:     {name}                                 # group kernel/ (from the kernel registry)
    method:     {name, <options of the method>}        # group method/
    model:      {_target_, <keyword arguments>}        # group model/ (Hydra instantiate)
    executor:   {kind, folder, n_jobs, params, address, jobqueue, cores_per_run, cores_env}   # group executor/
    priors:     {<parameter>: {dist, a, b, ..., label, unit}}   # group priors/ (Tables 2 and 4)
    data:       {path, format, missing, lines, odisi, dic, campaign_seed, loads, resolution, pitch}
    predict:    {loads, n}
    likelihood: {sigma_m, sigma_e, match, discrepancy}
    seed, store
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Dict, List, Optional

from omegaconf import MISSING

from torchshm.kernels import kernel_names

# OmegaConf reads the annotations at runtime and does not accept PEP 604 unions (``X | None``)
# or built-in generics (``list[float]``) in structured configs, hence the ``typing`` forms.


#: The registered discrepancy kernels (:func:`torchshm.kernels.kernel_names`, the paper's
#: Table 6 and any kernel class defined before this module is imported), one member each.
KernelName = Enum("KernelName", {name: name for name in kernel_names()}, module=__name__)


class ModelName(Enum):
    """The shipped model configs (``conf/model/<name>.yaml``) of bridge 705."""

    fe = "fe"  # _target_: torchshm.bridge705, the finite element model
    surrogate = "surrogate"  # _target_: torchshm.bridge705_surrogate, its GP surrogate


class Distribution(Enum):
    """Prior families; ``fixed`` pins the parameter to ``value`` (it is then not inferred)."""

    uniform = "uniform"  # a, b (the hard bounds are (a, b))
    gamma = "gamma"  # alpha, beta (rate); optional bounds
    normal = "normal"  # mean, sd; optional bounds
    fixed = "fixed"  # value


@dataclass
class KernelConfig:
    """Discrepancy kernel (group ``kernel/``)."""

    name: KernelName = KernelName.matern32


@dataclass
class ModelConfig:
    """Forward model (group ``model/``): what Hydra's ``instantiate`` builds.

    ``_target_`` is the dotted path of a class or factory (importable from the directory the
    command runs from, or installed), and every other key of the node is a keyword argument,
    e.g. ``{_target_: torchshm.ExternalModel, command: [...], x: [...], loads: [...]}``; for
    ``ExternalModel`` and ``TemplateModel``, ``x`` and ``loads`` may also be a range
    ``{start: 0.0, stop: 20.0, num: 201}`` or a ``.csv``/``.npy`` file path, and ``keep``
    (``failed``, ``all``, ``none``) says which run folders stay. The node is kept as a plain
    dict (:attr:`Config.model`); this class documents the shipped default only.
    """

    _target_: str = "torchshm.bridge705_surrogate"


@dataclass
class ExecutorConfig:
    """Where forward-model runs go (group ``executor/``): the arguments of
    :func:`torchshm.storage.evaluation_options` (``kind`` serial, joblib, dask, local, slurm,
    debug)."""

    kind: str = "serial"
    folder: str = "runs/submitit"  # submitit's job folder (local, slurm, debug)
    n_jobs: int = 1  # worker processes (joblib, dask); -1: as many as fit; dask + jobqueue: batch jobs
    params: Dict[str, Any] = field(default_factory=dict)  # submitit parameters, or the Dask cluster's options
    address: Optional[str] = None  # dask: a running scheduler, e.g. tcp://10.0.0.5:8786; None starts a cluster
    jobqueue: Optional[str] = None  # dask: slurm, pbs, sge, lsf, htcondor, oar or moab (dask-jobqueue)
    cores_per_run: Optional[int] = None  # threads of one run (OMP_NUM_THREADS, ...); None: as they are
    cores_env: List[str] = field(default_factory=list)  # the program's own thread variables


@dataclass
class MethodConfig:
    """Base of the method schemas (group ``method/``); ``name`` selects the method.

    A method's schema is a subclass whose ``name`` defaults to the method's registered name
    (:mod:`torchshm.inference.registry`) and whose other fields are its runner's options; it is
    stored as ``method_schema_<name>`` for ``conf/method/<name>.yaml`` to extend.
    """

    name: str = MISSING


@dataclass
class VBMCConfig(MethodConfig):
    """Options of VBMC (PyVBMC); ``None`` keeps PyVBMC's default."""

    name: str = "vbmc"
    max_fun_evals: Optional[int] = None  # budget of log-joint (model) evaluations
    max_model_evaluations: Optional[int] = None  # the same budget under the emulator's name
    n_samples: int = 100_000  # samples drawn from the variational posterior


@dataclass
class EmceeConfig(MethodConfig):
    """Options of the affine-invariant ensemble sampler (emcee); the paper's A1 settings."""

    name: str = "emcee"
    n_walkers: int = 40
    n_steps: int = 2000
    burn: Optional[int] = None  # steps discarded before the summaries; None = n_steps // 2
    thin: int = 1  # keep every thin-th step after burn-in
    log_every: int = 100  # steps between trace rows (TensorBoard, trace.png)
    window: int = 1000  # samples behind each trace row's running marginals (paper, Fig. 5)
    backend_path: Optional[str] = None  # HDF5 chain file, resumed when it exists
    max_model_evaluations: Optional[int] = None  # cap on model runs: at most this // n_walkers - 1 steps


@dataclass
class EmulatorConfig(MethodConfig):
    """Options of the FE-efficient method (adaptive field emulator, batches of model runs).

    The runs of a batch go where ``executor`` says (group ``executor/``), through ``store``.
    """

    name: str = "emulator"
    batch_size: int = 5  # model runs per round, evaluated concurrently
    max_model_evaluations: Optional[int] = None  # cap on model runs; None = 50 (D + 2), PyVBMC's
    n_initial: Optional[int] = None  # initial design; None = a multiple of batch_size >= 2 P + 1
    n_walkers: Optional[int] = None  # emcee walkers on the emulated posterior; None = max(96, 12 D)
    n_steps: int = 50  # emcee steps per round on the emulated posterior (no model runs)
    final_steps: int = 50  # emcee steps on the last emulator (fits the posterior density)
    tv_tol: float = 0.05  # stop when successive posteriors differ by less (total variation) ...
    patience: int = 1  # ... in this many successive rounds
    sd_tol: float = 0.3  # ... the emulator's log-likelihood sd is below this [nats]
    check_tol: float = 1.0  # ... and the last batch was within this of the emulator [nats]
    n_evidence: int = 8000  # importance samples of the log evidence and the posterior draws
    emulator_kernel: str = "matern52_additive_warped"  # GP kernel of the field emulator: any of torchshm.surrogate.gp.SURROGATE_KERNELS
    error_draws: Optional[int] = None  # unconverged: emulator draws averaged over; None = 8-32 by time


@dataclass
class PriorConfig:
    """One prior (group ``priors/``); only the fields of ``dist`` may be set.

    ``label`` and ``unit`` only name the parameter in plots and tables (any family).

    ``bounds`` are the hard bounds ``[lower, upper]`` of a gamma or normal prior (a uniform
    prior's are ``[a, b]``); ``plausible`` the plausible bounds VBMC needs (paper, Table 4).
    """

    dist: Distribution = MISSING
    a: Optional[float] = None
    b: Optional[float] = None
    alpha: Optional[float] = None
    beta: Optional[float] = None
    mean: Optional[float] = None
    sd: Optional[float] = None
    value: Optional[float] = None
    bounds: Optional[List[float]] = None
    plausible: Optional[List[float]] = None
    label: Optional[str] = None  # axis label in plots (default: the parameter name)
    unit: Optional[str] = None  # unit shown after the label, e.g. GPa


@dataclass
class DataConfig:
    """Measurements used for inference."""

    path: Optional[str] = None  # CSV, .nc, ODiSI .tsv file or DIC exports (a glob); None = synthetic_campaign
    format: Optional[str] = None  # csv, netcdf, odisi or dic; None: from the file's suffix (dic never guessed)
    missing: Optional[str] = None  # error or mask (NaN readings are dropouts); None: what the file says
    lines: Optional[Any] = None  # synthetic campaign: 1 or 2 fibres; odisi: {label: segment, [gauges] or [x0, x1]}
    odisi: Dict[str, Any] = field(default_factory=dict)  # other options of the ODiSI reader (windows, tare, ...)
    dic: Dict[str, Any] = field(default_factory=dict)  # DIC reader options (loads, preset, columns, scale, ...)
    campaign_seed: int = 0
    loads: List[float] = field(default_factory=lambda: [39.8])  # front-axle positions [m]
    resolution: Optional[float] = 0.1  # spacing of kept positions [m] (group resolution/); None: all
    pitch: Optional[float] = None  # reading pitch of the synthetic campaign [m]; None: shipped 0.1 m


@dataclass
class PredictConfig:
    """Held-out load cases for the posterior predictive check (empty list: none)."""

    loads: List[float] = field(default_factory=lambda: [47.5, 55.1, 62.8, 70.4])
    n: int = 2000  # posterior predictive draws


@dataclass
class LikelihoodConfig:
    """The noise levels of Eq. (21) (fixed, or inferred when given a prior) and the data view."""

    # a number, or a prior ({dist: uniform, a: 0, b: 0.2}, as a priors entry): then inferred
    sigma_m: Any = 0.05  # multiplicative model error (relative)
    sigma_e: Any = None  # measurement noise [µε]; None = the file's value; a prior: one level inferred
    match: str = "exact"  # measured positions onto the model's: exact or interpolate (along each line)
    discrepancy: str = "shared"  # sigma_a and length shared by the lines, or per_line


@dataclass
class Config:
    """The whole ``torchshm-identify`` configuration."""

    kernel: KernelConfig = MISSING
    method: MethodConfig = MISSING
    model: Any = MISSING  # a ModelConfig-like node: {_target_, <keyword arguments>}
    executor: ExecutorConfig = field(default_factory=ExecutorConfig)
    priors: Dict[str, PriorConfig] = MISSING
    data: DataConfig = field(default_factory=DataConfig)
    predict: PredictConfig = field(default_factory=PredictConfig)
    likelihood: LikelihoodConfig = field(default_factory=LikelihoodConfig)
    seed: int = 0
    store: Optional[str] = None  # evaluation store (SQLite); relative to the working directory


__all__ = [
    "Config",
    "DataConfig",
    "Distribution",
    "EmceeConfig",
    "EmulatorConfig",
    "ExecutorConfig",
    "KernelConfig",
    "KernelName",
    "LikelihoodConfig",
    "MethodConfig",
    "ModelConfig",
    "ModelName",
    "PredictConfig",
    "PriorConfig",
    "VBMCConfig",
]
