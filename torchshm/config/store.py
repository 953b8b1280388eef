"""Registration of the schemas with Hydra, and the helpers that compose ``conf/``.

:func:`register_configs` must run before Hydra composes ``conf/config.yaml`` (the CLI and the
tests call it); it is idempotent. The schemas are stored as ``config_schema`` and, one per
method, ``method_schema_<method>`` (e.g. ``method_schema_vbmc``), which the YAML files list
first in their defaults lists (Hydra's "structured config as schema" pattern). They are
top-level configs, not a group, so ``--help`` lists only the groups a user selects.

The options of the ``kernel`` group are not files: one ``kernel/<name>`` entry is stored for
every registered kernel class (:func:`torchshm.kernels.kernel_names`), so a kernel class is
selectable as ``kernel=<name>`` as soon as it is defined.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import fields as dataclass_fields
from pathlib import Path

from hydra.core.config_store import ConfigStore
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import ChoiceSweep, OverrideType
from hydra.errors import HydraException
from omegaconf import MISSING, OmegaConf

from torchshm.config.schema import Config, KernelConfig, KernelName, MethodConfig, PriorConfig
from torchshm.kernels import kernel_names

#: the application's config directory (``conf/`` at the root of the source tree)
CONF_DIR = Path(__file__).resolve().parents[2] / "conf"
#: name of the primary config file in :data:`CONF_DIR`
CONFIG_NAME = "config"
#: config groups whose options are numbers (``resolution=0.5`` selects ``resolution/0.5.yaml``)
NUMERIC_GROUPS = ("resolution",)
#: longest run-folder name made from the overrides before it is shortened with a hash
MAX_DIRNAME = 200

#: fields of a prior entry that a replacing entry keeps when it does not give them
_KEPT_FIELDS = ("label", "unit")
_PARSER = OverridesParser.create()

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"


def register_configs() -> None:
    """Store the schemas in Hydra's ConfigStore and register the ``torchshm.dirname`` resolver."""
    cs = ConfigStore.instance()
    cs.store(name="config_schema", node=Config)
    for schema in _method_schemas():
        cs.store(name=f"method_schema_{schema.name}", node=schema)
    for name in kernel_names():
        if name in KernelName.__members__:  # a kernel defined after the schema has no member
            cs.store(group="kernel", name=name, node=KernelConfig(name=KernelName[name]))
    if not OmegaConf.has_resolver("torchshm.dirname"):
        OmegaConf.register_new_resolver("torchshm.dirname", run_dirname)


def _method_schemas() -> list[type[MethodConfig]]:
    """Every schema subclass of :class:`MethodConfig` that names its method (any depth)."""
    found, todo = [], list(MethodConfig.__subclasses__())
    while todo:
        schema = todo.pop(0)
        todo.extend(schema.__subclasses__())
        if isinstance(getattr(schema, "name", None), str) and schema.name != MISSING:
            found.append(schema)
    return found


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
    ``1.0`` selects ``1.yaml``). A whole prior entry given on the command line replaces the
    entry (:func:`replace_prior_override`); every other override is returned unchanged.
    """
    groups = "|".join(re.escape(g) for g in NUMERIC_GROUPS)
    pattern = re.compile(rf"^(?P<key>(?:{groups}))=(?P<values>{_NUMBER}(?:,{_NUMBER})*)$")
    out = []
    for item in overrides:
        match = pattern.match(item)
        if match is None:
            out.append(replace_prior_override(item))
            continue
        values = ",".join(f"'{float(v):g}'" for v in match["values"].split(","))
        out.append(f"{match['key']}={values}")
    return out


def replace_prior_override(item: str) -> str:
    """``priors.<name>={...}`` rewritten so that the new entry replaces the old one.

    Hydra merges a dict given on the command line into the node it overrides, so
    ``priors.<name>={dist:normal,mean:35,sd:5}`` would keep the ``a``, ``b`` and ``plausible``
    of a uniform prior. Here every distribution field the new entry leaves out is set to
    ``null`` (``label`` and ``unit`` are kept unless given); a sweep of entries is rewritten
    entry by entry. Anything else, including a malformed override (Hydra reports it), is
    returned unchanged.
    """
    if not item.startswith("priors.") or "={" not in item:
        return item
    try:
        override = _PARSER.parse_overrides([item])[0]
    except HydraException:
        return item
    key = override.key_or_group
    if override.type is not OverrideType.CHANGE or override.package or key.count(".") != 1:
        return item
    value = override.value()
    entries = value.list if isinstance(value, ChoiceSweep) else [value]
    if not entries or not all(isinstance(e, dict) for e in entries):
        return item
    fields = [f.name for f in dataclass_fields(PriorConfig) if f.name not in _KEPT_FIELDS]
    text = ",".join(_hydra_literal({**{f: None for f in fields}, **e}) for e in entries)
    return f"{key}={text}"


def _hydra_literal(value: object) -> str:
    """``value`` (dict, list, str, number, bool, None) in Hydra's override grammar."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{" + ",".join(f"{k}:{_hydra_literal(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_hydra_literal(v) for v in value) + "]"
    if isinstance(value, (int, float)):
        return repr(value)
    text = str(value).replace("\\", "\\\\").replace("'", "\\'")
    return f"'{text}'"


__all__ = [
    "CONFIG_NAME",
    "CONF_DIR",
    "NUMERIC_GROUPS",
    "normalize_overrides",
    "register_configs",
    "replace_prior_override",
    "run_dirname",
]
