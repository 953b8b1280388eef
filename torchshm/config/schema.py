"""Structured-config schemas of the ``torchshm-identify`` application.

Each dataclass types one node of ``conf/config.yaml``; Hydra validates the YAML files and every
command-line override against them (a misspelt key or a string where a number belongs is
reported before anything runs). The defaults below mirror the YAML files in ``conf/`` so that
the schema alone documents each option; the YAML files are what users read and edit.

Layout of the composed config::

    kernel:     {name}                                 # group kernel/
    method:     {name, <options of the method>}        # group method/
    model:      {name}                                 # group model/
    priors:     {<parameter>: {dist, a, b, ...}}       # group priors/ (Tables 2 and 4)
    data:       {path, campaign_seed, loads, resolution}   # resolution from group resolution/
    predict:    {loads, n}
    likelihood: {sigma_m, sigma_e}
    seed, store
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Dict, List, Optional

from omegaconf import MISSING

# OmegaConf reads the annotations at runtime and does not accept PEP 604 unions (``X | None``)
# or built-in generics (``list[float]``) in structured configs, hence the ``typing`` forms.


class KernelName(Enum):
    """The discrepancy kernels of the paper's Table 6 (``torchshm.KERNELS``)."""

    independent = "independent"
    exponential = "exponential"
    matern32 = "matern32"
    matern52 = "matern52"
    squared_exponential = "squared_exponential"


class ModelName(Enum):
    """The shipped forward models of bridge 705."""

    fe = "fe"  # torchshm.bridge705(): the finite element model
    surrogate = "surrogate"  # torchshm.bridge705_surrogate(): its GP surrogate


class MethodName(Enum):
    """The inference methods of :func:`torchshm.identify`."""

    vbmc = "vbmc"
    emcee = "emcee"


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
    """Forward model (group ``model/``)."""

    name: ModelName = ModelName.surrogate


@dataclass
class MethodConfig:
    """Base of the method schemas (group ``method/``); ``name`` selects the method."""

    name: MethodName = MISSING


@dataclass
class VBMCConfig(MethodConfig):
    """Options of VBMC (PyVBMC); ``None`` keeps PyVBMC's default."""

    name: MethodName = MethodName.vbmc
    max_fun_evals: Optional[int] = None  # budget of log-joint (model) evaluations
    n_samples: int = 100_000  # samples drawn from the variational posterior


@dataclass
class EmceeConfig(MethodConfig):
    """Options of the affine-invariant ensemble sampler (emcee); the paper's A1 settings."""

    name: MethodName = MethodName.emcee
    n_walkers: int = 40
    n_steps: int = 2000
    burn: Optional[int] = None  # steps discarded before the summaries; None = n_steps // 2
    thin: int = 1  # keep every thin-th step after burn-in
    log_every: int = 100  # steps between trace rows (TensorBoard, trace.png)
    window: int = 1000  # samples behind each trace row's running marginals (paper, Fig. 5)
    backend_path: Optional[str] = None  # HDF5 chain file, resumed when it exists


@dataclass
class PriorConfig:
    """One prior (group ``priors/``); only the fields of ``dist`` may be set.

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


@dataclass
class DataConfig:
    """Measurements used for inference."""

    path: Optional[str] = None  # CSV or .nc file; None = torchshm.synthetic_campaign(campaign_seed)
    campaign_seed: int = 0
    loads: List[float] = field(default_factory=lambda: [39.8])  # front-axle positions [m]
    resolution: Optional[float] = 0.1  # spacing of kept positions [m] (group resolution/); None: all


@dataclass
class PredictConfig:
    """Held-out load cases for the posterior predictive check (empty list: none)."""

    loads: List[float] = field(default_factory=lambda: [47.5, 55.1, 62.8, 70.4])
    n: int = 2000  # posterior predictive draws


@dataclass
class LikelihoodConfig:
    """Fixed parameters of Eq. (21)."""

    sigma_m: float = 0.05  # multiplicative model error (relative)
    sigma_e: Optional[float] = None  # measurement noise [µε]; None = the file's value


@dataclass
class Config:
    """The whole ``torchshm-identify`` configuration."""

    kernel: KernelConfig = MISSING
    method: MethodConfig = MISSING
    model: ModelConfig = MISSING
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
    "KernelConfig",
    "KernelName",
    "LikelihoodConfig",
    "MethodConfig",
    "MethodName",
    "ModelConfig",
    "ModelName",
    "PredictConfig",
    "PriorConfig",
    "VBMCConfig",
]
