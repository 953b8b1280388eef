"""Reader of Luna ODiSI ``.tsv`` exports (gauge/segment files and full files).

Layout of the export (tab-separated), as read by python-odisi and fosanalysis:

1. a metadata block of ``Key:<TAB>value`` lines, ended by a line starting with ``----``;
2. in a gauge file, a ``Gage/Segment Name`` row: three label cells, then one name per column:
   gauges by name, then segments as ``name[0]``, ``name[1]``, ...;
3. an ``x-axis`` row: the position of each column along the fibre [m];
4. a ``tare`` row: the tare strain of each column [µε];
5. time-stamped rows ``YYYY-MM-DD HH:MM:SS.ffffff<TAB>measurement<TAB>strain<TAB>values...``,
   strains in microstrain relative to the tare; an empty or ``nan`` cell is a lost reading.

The first three cells of rows 2-4 are labels (the first names the row), as in the export.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from torchshm.data.anomaly import anomaly_mask
from torchshm.data.formats import Format, register_format
from torchshm.data.measurements import Measurements


@dataclass
class OdisiFile:
    """One parsed export: metadata, column names (gauge files), x-axis [m], tare and rows [µε]."""

    metadata: dict[str, str]
    names: list[str] | None
    x: np.ndarray
    tare: np.ndarray
    times: list[dt.datetime]
    rows: np.ndarray


def parse(path: str | Path) -> OdisiFile:
    """Parse an export; ``ValueError`` naming the file and the row for a malformed one."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"ODiSI file not found: {path}")
    try:
        text = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file ({err.reason} at byte {err.start})") from None
    end = next((k for k, t in enumerate(text) if t.startswith("----")), None)
    if end is None:
        raise ValueError(f"{path}: no '----' line ending the metadata block (not an ODiSI .tsv export)")
    metadata = {}
    for t in text[:end]:
        key, _, value = t.partition(":")
        metadata[key.strip()] = value.strip()
    k, names = end + 1, None
    body = [(j + 1, t.rstrip("\r\n").split("\t")) for j, t in enumerate(text) if j > end and t.strip()]
    if body and body[0][1][0].strip().lower().startswith("gage/segment"):
        names = [v.strip() for v in body[0][1][3:]]
        body = body[1:]
    rows: dict[str, np.ndarray] = {}
    for label in ("x-axis", "tare"):
        if not body or body[0][1][0].strip().lower() != label:
            found = f"{body[0][1][0][:40]!r}" if body else "end of file"
            where = f"line {body[0][0]}" if body else "end"
            raise ValueError(f"{path}, {where}: expected the {label!r} row, found {found}")
        rows[label] = _numbers(body[0], path, names)
        body = body[1:]
    width = rows["x-axis"].size
    if names is not None and len(names) != width:
        raise ValueError(f"{path}: {len(names)} gauge/segment names but {width} x-axis values")
    times, data = [], np.empty((len(body), width))
    for r, (number, cells) in enumerate(body):
        try:
            times.append(dt.datetime.fromisoformat(cells[0].strip()))
        except ValueError:
            raise ValueError(f"{path}, line {number}: {cells[0][:40]!r} is not a date and time") from None
        values = _numbers((number, cells), path, names)
        if values.size != width:
            raise ValueError(f"{path}, line {number}: {values.size} values, expected {width} as in the x-axis row")
        data[r] = values
    if not times:
        raise ValueError(f"{path}: no time-stamped rows after the tare row")
    if not np.all(np.isfinite(rows["x-axis"])):
        raise ValueError(f"{path}: the x-axis row has an empty or non-finite value")
    return OdisiFile(metadata, names, rows["x-axis"], rows["tare"], times, data)


def _numbers(row: tuple[int, list[str]], path: Path, names: list[str] | None) -> np.ndarray:
    number, cells = row
    values = cells[3:]
    out = np.empty(len(values))
    for c, v in enumerate(values):
        v = v.strip()
        try:
            out[c] = float(v) if v else np.nan
        except ValueError:
            col = f" ({names[c]})" if names is not None and c < len(names) else ""
            raise ValueError(f"{path}, line {number}, column {c + 4}{col}: {v[:40]!r} is not a number") from None
        if np.isinf(out[c]):
            raise ValueError(f"{path}, line {number}, column {c + 4}: {v!r} is infinite")
    return out


def _columns(f: OdisiFile, spec: object, label: object) -> np.ndarray:
    """Column indices of one line: a segment name, a list of gauge names, or an x-axis range [m]."""
    if isinstance(spec, str):
        if f.names is None:
            raise ValueError(f"line {label!r}: segment {spec!r} named, but the file has no gauge/segment row")
        cols = [c for c, n in enumerate(f.names) if n.startswith(spec + "[")] or \
            [c for c, n in enumerate(f.names) if n == spec]
        if not cols:
            raise ValueError(f"line {label!r}: no segment or gauge {spec!r} in the file")
        return np.array(cols)
    if isinstance(spec, tuple) and len(spec) == 2 and all(isinstance(v, (int, float)) for v in spec):
        cols = np.flatnonzero((f.x >= spec[0] - 1e-9) & (f.x <= spec[1] + 1e-9))
        if cols.size == 0:
            raise ValueError(f"line {label!r}: no x-axis value within {spec} m")
        return cols
    if isinstance(spec, (list, tuple)) and all(isinstance(v, str) for v in spec):
        return np.concatenate([_columns(f, v, label) for v in spec])
    raise ValueError(f"line {label!r}: give a segment name, a list of gauge names or an (x0, x1) range, got {spec!r}")


def read_odisi(
    path: str | Path | Mapping[float, str | Path],
    lines: Mapping[object, object] | None = None,
    windows: Mapping[float, tuple[object, object]] | None = None,
    tare: str = "file",
    reference: tuple[object, object] | None = None,
    anomaly: float | None = None,
    anomaly_radius: int = 3,
    sigma_e: float | Mapping[object, float] = 0.1,
    missing: str = "error",
    attrs: Mapping[str, object] | None = None,
) -> Measurements:
    """Measurements from ODiSI exports: one file with load-case time windows, or one file per load.

    Args:
        path: an export, or a mapping load case [m] -> export (all its rows form that load case).
        lines: line label -> a segment name, a list of gauge names, or an x-axis range ``(x0, x1)``
            [m]; ``None`` takes every column as one unnamed line.
        windows: with one file, load case [m] -> ``(start, end)`` times (ISO strings or
            datetimes, inclusive); the rows in each window are averaged reading by reading.
        tare: ``"file"`` keeps the readings as exported (relative to the tare row); ``"add"``
            adds the tare row back (readings relative to the interrogator's reference).
        reference: optional ``(start, end)`` window of unloaded rows whose mean is subtracted.
        anomaly: threshold [µε] of the anomaly rule (:mod:`torchshm.data.anomaly`) applied to
            each row before averaging; flagged readings become NaN. ``None`` flags nothing.
        anomaly_radius: neighbours on each side for that rule.
        sigma_e, missing, attrs: as for :class:`Measurements`.

    Raises:
        ValueError: naming the file and row of a malformed export, or the bad option.
    """
    if tare not in ("file", "add"):
        raise ValueError(f"read_odisi: tare must be 'file' or 'add', got {tare!r}")
    if isinstance(path, Mapping):
        if windows is not None:
            raise ValueError("read_odisi: give windows with one file, or one file per load case, not both")
        files = {float(k): parse(v) for k, v in path.items()}
        first = next(iter(files.values()))
        for load, f in files.items():
            if f.x.shape != first.x.shape or not np.array_equal(f.x, first.x):
                raise ValueError(f"read_odisi: the file of load {load:g} has other x-axis positions than the first")
        picks = {load: (f, np.ones(len(f.times), bool)) for load, f in files.items()}
    else:
        first = parse(path)
        if not windows:
            raise ValueError("read_odisi: name the load cases, windows={load: (start, end)}, or one file per load")
        picks = {float(k): (first, _in(first, w, f"load {k}")) for k, w in windows.items()}
    specs = {None: slice(None)} if lines is None else {k: _columns(first, v, k) for k, v in lines.items()}
    cols = np.concatenate([np.arange(first.x.size)[s] for s in specs.values()])
    label = None if lines is None else [k for k, s in specs.items() for _ in np.arange(first.x.size)[s]]
    y = np.empty((len(picks), cols.size))
    for i, (f, rows) in enumerate(picks.values()):
        data = f.rows + (f.tare if tare == "add" else 0.0)
        if reference is not None:
            data = data - _mean(data[_in(f, reference, "reference")])
        block = data[rows][:, cols]
        if anomaly is not None:
            start = 0
            for s in specs.values():
                width = np.arange(first.x.size)[s].size
                part = block[:, start:start + width]
                part[anomaly_mask(part, anomaly, anomaly_radius)] = np.nan
                start += width
        y[i] = _mean(block)
    return Measurements(first.x[cols], y, list(picks), sigma_e, attrs, line=label, missing=missing)


def _in(f: OdisiFile, window: Sequence[object], what: str) -> np.ndarray:
    try:
        a, b = (v if isinstance(v, dt.datetime) else dt.datetime.fromisoformat(str(v)) for v in window)
    except (TypeError, ValueError):
        raise ValueError(f"read_odisi: window of {what} must be two date-times, got {window!r}") from None
    try:
        rows = np.array([a <= t <= b for t in f.times])
    except TypeError:  # a time zone on one side only
        raise ValueError(f"read_odisi: window of {what} and the file's times differ in time zone") from None
    if not rows.any():
        raise ValueError(f"read_odisi: no time-stamped row within the window of {what} ({a} to {b})")
    return rows


def _mean(block: np.ndarray) -> np.ndarray:
    """Mean over rows reading by reading, NaN ignored; NaN where every row is NaN."""
    count = np.isfinite(block).sum(axis=0)
    total = np.where(np.isfinite(block), block, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


__all__ = ["OdisiFile", "parse", "read_odisi"]


def _read(path: object, format: str | None, missing: str | None, **options: object) -> Measurements:
    return read_odisi(path, missing=missing or "error", **options)  # type: ignore[arg-type]


#: Luna ODiSI ``.tsv`` exports
ODISI = register_format(Format("odisi", _read, suffixes=(".tsv",), options=True))
