"""From a composed ``DictConfig`` to typed settings: the only place a ``DictConfig`` is read."""

from __future__ import annotations

from dataclasses import fields, is_dataclass

from omegaconf import DictConfig, OmegaConf

from torchshm.config.schema import Config, MethodConfig


def to_settings(cfg: DictConfig) -> Config:
    """The composed config as a :class:`~torchshm.config.schema.Config` dataclass.

    Nested nodes become their schema dataclasses (``method`` a ``VBMCConfig`` or
    ``EmceeConfig``), enums become :class:`~enum.Enum` members, lists become lists.

    Raises:
        ValueError: when a key is not in the schema (Hydra lets ``+key=value`` add one), a
            mandatory value is missing or the config was not composed against the schema.
    """
    check_known_keys(cfg)
    try:
        settings = OmegaConf.to_object(cfg)
    except Exception as err:  # omegaconf's errors: a missing or invalid value
        raise ValueError(f"config: {_first_line(err)}") from None
    if not isinstance(settings, Config):
        raise ValueError("config: not composed against the torchshm schema (register_configs())")
    return settings


def check_known_keys(node: DictConfig, path: str = "") -> None:
    """Reject keys that the schema of their node does not declare, at any depth.

    Raises:
        ValueError: ``config: unknown key '<full key>' ...`` for the first such key.
    """
    schema = OmegaConf.get_type(node)
    known = {f.name for f in fields(schema)} if schema is not None and is_dataclass(schema) else None
    for key in node.keys():
        full = f"{path}.{key}" if path else str(key)
        if known is not None and key not in known:
            raise ValueError(f"config: unknown key {full!r} (not in the schema {schema.__name__})")
        child = node._get_node(key)  # the node itself, without resolving interpolations
        if isinstance(child, DictConfig) and not child._is_missing() and not child._is_none():
            check_known_keys(child, full)


def method_options(method: MethodConfig) -> dict[str, object]:
    """Keyword options of :func:`torchshm.identify` for ``method`` (unset ones left out)."""
    return {
        f.name: getattr(method, f.name)
        for f in fields(method)
        if f.name != "name" and getattr(method, f.name) is not None
    }


def _first_line(err: BaseException) -> str:
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[0] if lines else type(err).__name__


__all__ = ["check_known_keys", "method_options", "to_settings"]
