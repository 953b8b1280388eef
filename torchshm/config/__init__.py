"""Hydra structured configs of the ``torchshm-identify`` application (``conf/``).

The only package besides :mod:`torchshm.cli` that sees a ``DictConfig``: :func:`to_settings`
turns the composed config into typed dataclasses, :func:`build_priors` into prior objects.
"""

from __future__ import annotations

from torchshm.config.convert import check_known_keys, method_options, to_settings
from torchshm.config.priors import build_prior, build_priors, parameter_labels
from torchshm.config.schema import (
    Config,
    DataConfig,
    Distribution,
    EmceeConfig,
    ExecutorConfig,
    KernelConfig,
    KernelName,
    LikelihoodConfig,
    MethodConfig,
    ModelConfig,
    ModelName,
    PredictConfig,
    PriorConfig,
    VBMCConfig,
)
from torchshm.config.store import (
    CONF_DIR,
    CONFIG_NAME,
    NUMERIC_GROUPS,
    normalize_overrides,
    register_configs,
    replace_prior_override,
    run_dirname,
)

__all__ = [
    "CONFIG_NAME",
    "CONF_DIR",
    "NUMERIC_GROUPS",
    "Config",
    "DataConfig",
    "Distribution",
    "EmceeConfig",
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
    "build_prior",
    "check_known_keys",
    "build_priors",
    "method_options",
    "normalize_overrides",
    "parameter_labels",
    "register_configs",
    "replace_prior_override",
    "run_dirname",
    "to_settings",
]
