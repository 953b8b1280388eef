"""Composition of ``conf/`` with Hydra's compose API."""

from __future__ import annotations

from typing import Callable

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import DictConfig

from torchshm.config import CONF_DIR, CONFIG_NAME, register_configs


@pytest.fixture
def compose_cfg() -> Callable[..., DictConfig]:
    """``compose_cfg(*overrides)`` -> the composed config (without the ``hydra`` node)."""
    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        yield lambda *overrides, **kw: compose(CONFIG_NAME, overrides=list(overrides), **kw)
