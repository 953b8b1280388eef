"""Extended measurement files: sensor lines, coordinates, NaN dropouts, per-line noise.

A file in the original layout (CSV ``load,x,strain``; netCDF ``strain(load, x)``) with no
dropouts is read and written by :mod:`torchshm.data.io`, unchanged. Everything else goes here:

- CSV, long format with the header naming any of ``line, load, x, y, z, strain`` (``load``,
  ``x`` and ``strain`` required; ``z`` needs ``y``), any row order. A ``nan`` strain is a dropout;
  with ``missing="mask"`` a reading absent from the table is one too. Metadata lines:
  ``# sigma_e=`` or ``# sigma_e_by_line=[[label, value], ...]``, ``# attrs={...}``,
  ``# lines=[...]`` (label order and type) and ``# missing=mask``.
- netCDF: ``strain(load, point)``, ``x(point)`` or ``x(point, axis)``, optional ``line(point)``;
  attributes ``sigma_e`` or ``sigma_e_by_line``, ``attrs``, ``lines``, ``missing``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from torchshm.data import io
from torchshm.data.formats import Format, register_format
from torchshm.data.measurements import Measurements

COLUMNS = ("line", "load", "x", "y", "z", "strain")


def save(m: Measurements, path: Path) -> Path:
    """Write `m` in the extended layout (format by suffix)."""
    suffix = path.suffix.lower()
    if suffix == ".csv":
        _save_csv(m, path)
    elif suffix == ".nc":
        _save_nc(m, path)
    else:
        raise ValueError(f"unknown measurement file type {suffix!r} of {path} (use .csv or .nc)")
    return path


def _meta(m: Measurements) -> dict[str, str]:
    meta = {"attrs": json.dumps(m.attrs, sort_keys=True)}
    if isinstance(m.sigma_e, dict):
        meta["sigma_e_by_line"] = json.dumps([[k, v] for k, v in m.sigma_e.items()])
    else:
        meta["sigma_e"] = repr(m.sigma_e)
    if m.line is not None:
        meta["lines"] = json.dumps(list(m.lines))
    if m.missing == "mask":
        meta["missing"] = "mask"
    return meta


def _save_csv(m: Measurements, path: Path) -> None:
    coords = ["x", "y", "z"][: 1 if m.x.ndim == 1 else m.x.shape[1]]
    names = (["line"] if m.line is not None else []) + ["load", *coords, "strain"]
    x = m.x.reshape(m.n, -1)
    with open(path, "w", encoding="utf-8") as f:
        f.write("# torchshm measurements, long format: load [m], x (y, z) [m], strain [µε]\n")
        f.write("".join(f"# {k}={v}\n" for k, v in _meta(m).items()))
        f.write(",".join(names) + "\n")
        for i, load in enumerate(m.loads):
            for j in range(m.n):
                fields = [] if m.line is None else [str(m.line[j])]
                fields += [f"{load:.17g}", *(f"{v:.17g}" for v in x[j]), f"{m.y[i, j]:.17g}"]
                f.write(",".join(fields) + "\n")


def load(path: Path, format: str | None, missing: str | None) -> Measurements:
    """Read a CSV or netCDF file of either layout; ``missing`` None means the file's own."""
    if not path.is_file():
        raise FileNotFoundError(f"measurement file not found: {path}")
    kind = {"csv": ".csv", "netcdf": ".nc", "nc": ".nc", None: path.suffix.lower()}.get(format, format)
    if kind not in (".csv", ".nc"):
        raise ValueError(f"unknown measurement file type {kind!r} of {path} (use .csv, .nc or format='odisi')")
    if missing not in (None, "error", "mask"):
        raise ValueError(f"missing must be 'error' or 'mask', got {missing!r}")
    try:
        if kind == ".csv":
            return _load_csv(path, missing)
        return _load_nc(path, missing)
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file ({err.reason} at byte {err.start})") from None
    except ValueError as err:
        if str(path) in str(err):
            raise
        raise ValueError(f"{path}: {err}") from None


def _load_csv(path: Path, missing: str | None) -> Measurements:
    lines = path.read_text(encoding="utf-8").splitlines()
    meta = {}
    start = 0
    for start, text in enumerate(lines):
        if not text.startswith("#"):
            break
        key, _, value = text[1:].strip().partition("=")
        meta[key.strip()] = value
    header = [h.strip().lower() for h in lines[start].split(",")] if start < len(lines) else []
    extended = {"line", "y", "z"} & set(header) or {"lines", "missing", "sigma_e_by_line"} & set(meta)
    if not extended and (missing or "error") == "error":  # the original layout, its own messages
        return _original(path, io.load if path.suffix.lower() == ".csv" else io._load_csv)
    if not header or not {"load", "x", "strain"} <= set(header) or not set(header) <= set(COLUMNS) \
            or len(set(header)) != len(header) or ("z" in header and "y" not in header):
        raise ValueError(
            f"header must name the columns [line,] load, x[, y[, z]], strain; got {lines[start] if header else ''!r}"
        )
    rows = [(k + 1, t.split(",")) for k, t in enumerate(lines[start + 1:], start + 1) if t.strip()]
    if not rows:
        raise ValueError("no data rows after the header")
    numeric = [c for c in header if c != "line"]
    table = np.empty((len(rows), len(numeric)))
    labels = []
    for r, (number, fields) in enumerate(rows):
        if len(fields) != len(header):
            raise ValueError(f"line {number}: expected {len(header)} values ({', '.join(header)}), got {len(fields)}")
        values = dict(zip(header, fields))
        try:
            table[r] = [float(values[c]) for c in numeric]
        except ValueError as err:
            raise ValueError(f"line {number}: malformed row ({err})") from None
        labels.append(values.get("line", "").strip())
    cols = {c: table[:, k] for k, c in enumerate(numeric)}
    coords = np.column_stack([cols[c] for c in ("x", "y", "z") if c in cols])
    for c in numeric:
        bad = ~np.isfinite(cols[c]) if c != "strain" else np.isinf(cols[c])
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"line {rows[i][0]}: {c} is {cols[c][i]}; it must be a finite number")
    line = _labels(labels, _line_order(meta)) if "line" in header else None
    return _grid(cols["load"], coords, line, cols["strain"], meta, missing, [n for n, _ in rows])


def _original(path: Path, reader) -> Measurements:
    """Read the original layout with its own messages; a NaN strain gets the dropout hint."""
    try:
        return reader(path)
    except ValueError as err:
        message = str(err)
        if "strain is nan" in message:
            raise ValueError(f"{message}; missing='mask' treats NaN readings as dropouts") from None
        raise


def _line_order(meta: dict) -> list | None:
    """The ``lines`` metadata: a JSON list of distinct int or str labels, or ``None``."""
    if "lines" not in meta:
        return None
    try:
        order = json.loads(meta["lines"])
    except ValueError:
        order = None
    if not isinstance(order, list) or not order or len({str(v) for v in order}) != len(order) \
            or not all(isinstance(v, (int, str)) and not isinstance(v, bool) for v in order):
        raise ValueError(f"malformed lines metadata {meta['lines'][:80]!r} (a JSON list of distinct labels)")
    return order


def _labels(text: list[str], order: list | None) -> list:
    """Line labels from their text: by the file's ``lines`` list, else int when all are ints."""
    if order is not None:
        lookup = {str(v): v for v in order}
        unknown = [t for t in text if t not in lookup]
        if unknown:
            raise ValueError(f"line {unknown[0]!r} is not among the file's lines {order}")
        return [lookup[t] for t in text]
    try:
        return [int(t) for t in text]
    except ValueError:
        return text


def _grid(load, coords, line, strain, meta, missing, numbers) -> Measurements:
    """Long table -> Measurements: loads and lines in order of first appearance, points sorted."""
    mode = missing or meta.get("missing", "error").strip()
    line_order = (_line_order(meta) if line is not None else None) or list(dict.fromkeys(line or [""]))
    line = ["" for _ in load] if line is None else line
    line_rank = {label: k for k, label in enumerate(line_order)}
    keys = np.column_stack([np.array([line_rank[v] for v in line], dtype=float), coords])
    points, pi = np.unique(keys, axis=0, return_inverse=True)  # sorted by line, then x (y, z)
    loads = np.array(list(dict.fromkeys(load.tolist())))
    index = {v: k for k, v in enumerate(loads.tolist())}
    li = np.array([index[v] for v in load.tolist()], dtype=np.int64)
    cell = li * points.shape[0] + pi.ravel()
    counts = np.bincount(cell, minlength=loads.size * points.shape[0])
    if counts.max() > 1:
        i = np.flatnonzero(cell == np.argmax(counts))[1]
        raise ValueError(f"line {numbers[i]}: load {load[i]:g} at this position{_on(line[i])} appears more than once")
    y = np.full((loads.size, points.shape[0]), np.nan)
    y[li, pi.ravel()] = strain
    absent = np.flatnonzero(counts == 0)
    if absent.size and mode != "mask":
        i, j = divmod(int(absent[0]), points.shape[0])
        raise ValueError(
            f"no strain for load {loads[i]:g} at x = {points[j, 1]:g} m{_on(line_order[int(points[j, 0])])} "
            f"({absent.size} absent reading(s)); missing='mask' treats them as dropouts"
        )
    labels = [line_order[int(k)] for k in points[:, 0]]
    x = points[:, 1] if points.shape[1] == 2 else points[:, 1:]
    return Measurements(x, y, loads, _sigma(meta), _attrs(meta), line=None if labels[0] == "" else labels,
                        missing=mode)


def _on(label) -> str:
    return "" if label == "" or label is None else f" on line {label!r}"


def _sigma(meta: dict):
    try:
        if "sigma_e_by_line" in meta:
            return {k: float(v) for k, v in json.loads(meta["sigma_e_by_line"])}
        return float(meta.get("sigma_e", 0.1))
    except (ValueError, TypeError):
        raise ValueError("malformed sigma_e metadata") from None


def _attrs(meta: dict) -> dict:
    try:
        return json.loads(meta.get("attrs", "{}"))
    except ValueError:
        raise ValueError("malformed 'attrs' attribute") from None


def _save_nc(m: Measurements, path: Path) -> None:
    import xarray as xr

    x = ("point", m.x) if m.x.ndim == 1 else (("point", "axis"), m.x)
    data = {"strain": (("load", "point"), m.y, {"units": "microstrain"}), "x": (*x, {"units": "m"})}
    if m.line is not None:
        data["line"] = ("point", m.line)
    meta = _meta(m)
    meta["format"] = "torchshm measurements"
    xr.Dataset(data, coords={"load": ("load", m.loads, {"units": "m"})}, attrs=meta).to_netcdf(path, engine="h5netcdf")


def _load_nc(path: Path, missing: str | None) -> Measurements:
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except Exception as err:  # noqa: BLE001 - any reader failure means a malformed file
        raise ValueError(f"{path}: not a readable netCDF file ({type(err).__name__}: {err})") from None
    meta = {k: str(v) for k, v in ds.attrs.items()}
    if "strain" in ds and ds["strain"].dims == ("load", "x"):
        if (missing or meta.get("missing", "error")) == "error":
            return _original(path, io.load)
        x = np.asarray(ds["x"].values, dtype=np.float64)
    elif "strain" in ds and ds["strain"].dims == ("load", "point") and "x" in ds:
        x = np.asarray(ds["x"].values, dtype=np.float64)
    else:
        raise ValueError("needs a variable 'strain' with dims (load, x) or (load, point)")
    line = None
    if "line" in ds:
        line = _labels([str(v) for v in ds["line"].values], _line_order(meta))
    return Measurements(x, np.asarray(ds["strain"].values, dtype=np.float64),
                        np.asarray(ds["load"].values, dtype=np.float64), _sigma(meta), _attrs(meta),
                        line=line, missing=missing or meta.get("missing", "error"))


def write(m: Measurements, path: Path) -> Path:
    """Write `m` to ``.csv`` or ``.nc``: one fibre with no NaN, 1-D positions and one noise
    level in the original layout (:mod:`.io`), anything else in the extended one."""
    if m.line is None and m.x.ndim == 1 and m.missing == "error" and not isinstance(m.sigma_e, dict):
        return io.save(m, Path(path))
    return save(m, Path(path))


def _read(path: object, format: str | None, missing: str | None) -> Measurements:
    return load(Path(path), format, missing)  # type: ignore[arg-type]


#: CSV (long format) and netCDF, either layout
CSV = register_format(Format("csv", _read, suffixes=(".csv",), write=write))
NETCDF = register_format(Format("netcdf", _read, suffixes=(".nc",), write=write))

__all__ = ["CSV", "NETCDF", "load", "save", "write"]
