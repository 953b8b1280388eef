"""Sensor positions and load cases given as numbers, a range or a file.

A forward model's ``x`` (sensor positions [m]) and ``loads`` (load cases) may be written in
Python or in a Hydra config in three ways::

    x: [0.0, 0.1, 0.2]                      # the values
    x: {start: 0.0, stop: 20.0, num: 201}   # numpy.linspace(start, stop, num), both ends included
    x: sensors.csv                          # a file: .csv/.txt (one column, or the column named
                                            # x; '#' comments) or .npy (a 1-D array)

A relative file path is relative to the current directory (the directory a
``torchshm-identify`` command runs from).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

RANGE_KEYS = ("start", "stop", "num")


def load_axis(values: object, name: str = "x") -> np.ndarray:
    """The 1-D float64 array ``values`` stands for: an array-like, a range or a file.

    Args:
        values: numbers (list, array, tensor), a mapping ``{start, stop, num}`` or the path of a
            ``.csv``/``.txt``/``.npy`` file.
        name: what the values are (``x`` or ``loads``), for messages and the CSV column.

    Returns:
        The values, shape `n`.

    Raises:
        ValueError: on a range with other keys or ``num < 1``, a missing or unreadable file,
            a file that does not hold one column of numbers, or values that are not a
            non-empty 1-D array of finite numbers.
    """
    if isinstance(values, Mapping):
        array = _range(values, name)
    elif isinstance(values, (str, os.PathLike)):
        array = _read(Path(values).expanduser(), name)
    else:
        if hasattr(values, "detach"):  # a torch tensor
            values = values.detach().cpu().numpy()  # type: ignore[union-attr]
        try:
            array = np.array(values, dtype=np.float64)
        except (TypeError, ValueError):
            array = np.empty((0, 0))
    if array.ndim != 1 or len(array) == 0 or not np.isfinite(array).all():
        raise ValueError(f"{name} must be a non-empty 1-D array of finite values")
    return array


def _range(spec: Mapping[str, object], name: str) -> np.ndarray:
    keys = set(spec)
    if keys != set(RANGE_KEYS):
        raise ValueError(f"{name}: a range needs exactly the keys start, stop, num, got {sorted(keys)}")
    num = spec["num"]
    if isinstance(num, bool) or not isinstance(num, int) or num < 1:
        raise ValueError(f"{name}: range num must be a positive integer, got {num!r}")
    try:
        start, stop = float(spec["start"]), float(spec["stop"])  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name}: range start and stop must be numbers, got {dict(spec)}") from None
    return np.linspace(start, stop, num)


def _read(path: Path, name: str) -> np.ndarray:
    if not path.is_file():
        raise ValueError(f"{name}: no file {path} (a relative path is relative to {Path.cwd()})")
    try:
        if path.suffix == ".npy":
            array = np.load(path, allow_pickle=False)
        elif path.suffix in (".csv", ".txt"):
            array = _read_text(path, name)
        else:
            raise ValueError(f"unknown format {path.suffix!r}, use .csv, .txt or .npy")
    except (OSError, ValueError) as exc:
        raise ValueError(f"{name}: cannot read {path}: {exc}") from None
    array = np.asarray(array, dtype=np.float64)
    if array.ndim != 1:
        raise ValueError(f"{name}: {path} holds an array of shape {array.shape}, expected one column")
    return array.copy()


def _read_text(path: Path, name: str) -> np.ndarray:
    """One column of numbers, or the column ``name`` of a table with a header line."""
    lines = [ln.strip() for ln in path.read_text(encoding="utf-8-sig").splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    delimiter = "," if any("," in ln for ln in lines) else None
    header = lines[0].split(delimiter) if lines else []
    try:
        float(header[0])
        rows = lines
        column = 0
    except (ValueError, IndexError):
        labels = [label.strip().lower() for label in header]
        if len(labels) > 1 and name not in labels:
            raise ValueError(f"no column {name!r} in the header {lines[0]!r}") from None
        column, rows = (labels.index(name) if name in labels else 0), lines[1:]
    table = np.loadtxt(rows, delimiter=delimiter, ndmin=2, dtype=np.float64)
    if table.shape[1] > 1 and column == 0 and rows is lines:
        raise ValueError(f"{table.shape[1]} columns and no header naming the column {name!r}")
    return table[:, column]


__all__ = ["RANGE_KEYS", "load_axis"]
