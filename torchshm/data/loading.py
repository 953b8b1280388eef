"""``load_measurements``: read any registered measurement file format (:mod:`.formats`).

Importing this module registers the shipped formats: CSV and netCDF (:mod:`.tables`, with the
original layout of :mod:`.io`), Luna ODiSI ``.tsv`` exports (:mod:`.odisi`) and
image-correlation exports (:mod:`.dic`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from torchshm.data import dic, odisi, tables  # noqa: F401  (each registers its format)
from torchshm.data.formats import find_format, format_of_suffix
from torchshm.data.measurements import Measurements


def load_measurements(
    path: str | Path | Mapping[float, str | Path], format: str | None = None, *, missing: str | None = None,
    **options: object,
) -> Measurements:
    """Read measurements from a ``.csv``, ``.nc``, Luna ODiSI ``.tsv`` or image-correlation file.

    Args:
        path: the file (for ``format="odisi"`` also a mapping load case -> file; for
            ``format="dic"`` a mapping load case -> export, a list or a glob pattern of exports).
        format: ``"csv"``, ``"netcdf"``, ``"odisi"`` or ``"dic"`` (or any registered format,
            :func:`~torchshm.data.formats.register_format`); ``None`` picks it by suffix
            (``.csv``, ``.nc``, ``.tsv``; a DIC export is never guessed).
        missing: ``"error"`` or ``"mask"`` (NaN cells kept as dropouts); ``None`` means what the
            file says (``# missing=mask``), else ``"error"``; a DIC field is always masked
            (``"error"`` refuses one with a lost subset).
        **options: for ``format="odisi"``, the options of :func:`torchshm.data.odisi.read_odisi`;
            for ``format="dic"``, those of :func:`torchshm.data.dic.read_dic` (``loads``,
            ``preset``, ``columns``, ``scale``, ...).

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: naming the problem, for a malformed file or invalid values.
    """
    format = None if format is None else str(format).lower()
    fmt = find_format(format)
    if format is None and not isinstance(path, Mapping):
        fmt = format_of_suffix(Path(path).suffix)
        format = None if fmt is None else fmt.name
    if fmt is None or not fmt.options:
        if options:
            raise TypeError(f"load_measurements: options {sorted(options)} apply to format='odisi' only "
                            "(format='dic' has its own)")
        if isinstance(path, Mapping):
            raise TypeError("load_measurements: one file per load case needs format='odisi' or 'dic'")
        fmt = fmt or tables.CSV  # the table reader refuses an unknown type, naming the file
    return fmt.read(path, format, missing, **options)
