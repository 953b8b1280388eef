"""Lazy public names of a package (PEP 562): a name's module is imported on its first use."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def lazy_getattr(package: str, exports: dict[str, str], namespace: dict[str, Any],
                 prefix: str = "") -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``.

    Args:
        package: the package's dotted name (for the error message).
        exports: public name -> module that defines it (``prefix`` + module is imported).
        namespace: the package's ``globals()``; a name, once imported, is cached there.
        prefix: prepended to every module of ``exports`` (e.g. ``"torchshm.casestudy."``).
    """

    def __getattr__(name: str) -> Any:
        try:
            module = exports[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(prefix + module), name)
        namespace[name] = value
        return value

    return __getattr__


def lazy_dir(exports: dict[str, str], namespace: dict[str, Any]) -> Callable[[], list[str]]:
    """The module ``__dir__`` of a package with lazy ``exports``: its loaded names and every
    export, sorted (``namespace``: the package's ``globals()``)."""

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __dir__


__all__ = ["lazy_dir", "lazy_getattr"]
