"""Registration of the schemas with Hydra, and the helpers that compose ``conf/``.

:func:`register_configs` must run before Hydra composes ``conf/config.yaml`` (the CLI and the
tests call it); it is idempotent. The schemas are stored as ``config_schema`` and
``schema/method/vbmc`` / ``schema/method/emcee``, which the YAML files list first in their
defaults lists (Hydra's "structured config as schema" pattern; a group of their own keeps them
out of the options of ``method``).
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf

from torchshm.config.schema import Config, EmceeConfig, VBMCConfig

#: the application's config directory (``conf/`` at the root of the source tree)
CONF_DIR = Path(__file__).resolve().parents[2] / "conf"
#: name of the primary config file in :data:`CONF_DIR`
CONFIG_NAME = "config"
#: config groups whose options are numbers (``resolution=0.5`` selects ``resolution/0.5.yaml``)
NUMERIC_GROUPS = ("resolution",)
#: longest run-folder name made from the overrides before it is shortened with a hash
MAX_DIRNAME = 200

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"


def register_configs() -> None:
    """Store the schemas in Hydra's ConfigStore and register the ``torchshm.dirname`` resolver."""
    cs = ConfigStore.instance()
    cs.store(name="config_schema", node=Config)
    cs.store(group="schema/method", name="vbmc", node=VBMCConfig)
    cs.store(group="schema/method", name="emcee", node=EmceeConfig)
    if not OmegaConf.has_resolver("torchshm.dirname"):
        OmegaConf.register_new_resolver("torchshm.dirname", run_dirname)


def run_dirname(overrides: str, prefix: str = "", empty: str = "") -> str:
    """A folder name made from Hydra's ``override_dirname`` (used in ``hydra.run.dir``).

    Quotes are dropped and path separators replaced, so that ``data.path=/a/b.csv`` or
    ``resolution='0.5'`` give one readable folder; a very long name is cut and ends in a hash.

    Args:
        overrides: ``${hydra.job.override_dirname}``, e.g. ``kernel=matern52,resolution=0.5``.
        prefix: put before a non-empty name (e.g. ``_`` after the time of day).
        empty: the name when there are no overrides.
    """
    name = re.sub(r"['\"]", "", str(overrides)).replace("/", "_").replace("\\", "_").strip()
    if not name:
        return empty
    if len(name) > MAX_DIRNAME:
        digest = hashlib.sha1(name.encode()).hexdigest()[:8]
        name = f"{name[: MAX_DIRNAME - 9]}_{digest}"
    return prefix + name


def normalize_overrides(overrides: list[str]) -> list[str]:
    """Quote the numeric options of :data:`NUMERIC_GROUPS` so Hydra reads them as names.

    Hydra's override parser turns ``resolution=0.5`` into the float 0.5, which it refuses as a
    config-group option. This rewrites ``resolution=0.5`` as ``resolution='0.5'`` and a sweep
    ``resolution=0.1,1.0`` as ``resolution='0.1','1'`` (numbers in their shortest form, so
    ``1.0`` selects ``1.yaml``). Every other override is returned unchanged.
    """
    groups = "|".join(re.escape(g) for g in NUMERIC_GROUPS)
    pattern = re.compile(rf"^(?P<key>(?:{groups}))=(?P<values>{_NUMBER}(?:,{_NUMBER})*)$")
    out = []
    for item in overrides:
        match = pattern.match(item)
        if match is None:
            out.append(item)
            continue
        values = ",".join(f"'{float(v):g}'" for v in match["values"].split(","))
        out.append(f"{match['key']}={values}")
    return out


__all__ = [
    "CONFIG_NAME",
    "CONF_DIR",
    "NUMERIC_GROUPS",
    "normalize_overrides",
    "register_configs",
    "run_dirname",
]
