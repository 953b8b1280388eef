"""Measurement file formats: a registry that each format's module fills when it is imported.

A format is a name (``format=`` of :func:`~torchshm.data.load_measurements`), the file suffixes
that choose it when no name is given, a reader and, for the formats :meth:`Measurements.save
<torchshm.data.Measurements.save>` writes, a writer. The shipped formats (CSV and netCDF in
:mod:`.tables`, Luna ODiSI in :mod:`.odisi`, image correlation in :mod:`.dic`) register
themselves and :mod:`.loading` imports them; a new format is one module that calls
:func:`register_format` and is imported before it is used.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Format:
    """One measurement file format.

    Attributes:
        name: the lower-case name given as ``format=``.
        read: ``read(path, format, missing, **options) -> Measurements``; ``missing`` is
            ``"error"``, ``"mask"`` or None (the file's own choice).
        suffixes: lower-case suffixes (``".csv"``) that pick the format when none is named.
        write: ``write(measurements, path) -> Path`` for a format that can be written.
        options: whether the reader takes keyword options and a mapping load case -> file
            (the per-load-case exports of a sensor or camera).
    """

    name: str
    read: Callable[..., Any]
    suffixes: tuple[str, ...] = ()
    write: Callable[[Any, Path], Path] | None = None
    options: bool = False


_FORMATS: dict[str, Format] = {}


def register_format(fmt: Format) -> Format:
    """Add ``fmt`` (a later registration of the same name replaces the earlier one)."""
    _FORMATS[fmt.name] = fmt
    return fmt


def find_format(name: str | None) -> Format | None:
    """The format called ``name``, or None."""
    return _FORMATS.get(name) if name is not None else None


def format_of_suffix(suffix: str) -> Format | None:
    """The format chosen by a file suffix (``".nc"``), or None when no format claims it."""
    return next((f for f in _FORMATS.values() if suffix.lower() in f.suffixes), None)


def format_names() -> tuple[str, ...]:
    """Names of the registered formats, in registration order."""
    return tuple(_FORMATS)


def write_measurements(measurements: Any, path: str | Path) -> Path:
    """Write ``measurements`` in the format its suffix names; returns the path.

    Raises:
        ValueError: when no registered format writes that suffix.
    """
    path = Path(path)
    fmt = format_of_suffix(path.suffix)
    if fmt is None or fmt.write is None:
        writable = sorted(s for f in _FORMATS.values() if f.write is not None for s in f.suffixes)
        raise ValueError(f"unknown measurement file type {path.suffix.lower()!r} of {path} "
                         f"(use {' or '.join(writable) or 'a registered format'})")
    return fmt.write(measurements, path)
