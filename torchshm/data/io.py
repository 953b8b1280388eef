"""Reading and writing :class:`~torchshm.data.measurements.Measurements` files.

``.csv`` is the long format a user can write from any logger (``load,x,strain``, one reading per
row, any row order, header required); ``.nc`` is netCDF-4 with the metadata kept as attributes.
Both round-trip float64 values exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from torchshm.data.measurements import Measurements

CSV_COLUMNS = ("load", "x", "strain")


def save(m: Measurements, path: Path) -> Path:
    """Write `m` to `path` (format by suffix)."""
    suffix = path.suffix.lower()
    if suffix == ".csv":
        _save_csv(m, path)
    elif suffix == ".nc":
        _save_nc(m, path)
    else:
        raise ValueError(f"unknown measurement file type {suffix!r} of {path} (use .csv or .nc)")
    return path


def load(path: Path) -> Measurements:
    """Read a measurement file (format by suffix)."""
    if not path.is_file():
        raise FileNotFoundError(f"measurement file not found: {path}")
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".nc"):
        raise ValueError(f"unknown measurement file type {suffix!r} of {path} (use .csv or .nc)")
    try:
        return _load_csv(path) if suffix == ".csv" else _load_nc(path)
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file ({err.reason} at byte {err.start})") from None
    except ValueError as err:  # e.g. from Measurements: say which file
        if str(path) in str(err):
            raise
        raise ValueError(f"{path}: {err}") from None


def _save_csv(m: Measurements, path: Path) -> None:
    loads = np.repeat(m.loads, m.n)
    x = np.tile(m.x, m.loads.size)
    table = np.column_stack([loads, x, m.y.reshape(-1)])
    header = "\n".join(
        [
            "torchshm measurements, long format: load [m], x [m], strain [µε]",
            f"sigma_e={m.sigma_e!r}",
            f"attrs={json.dumps(m.attrs, sort_keys=True)}",
        ]
    )
    with open(path, "w", encoding="utf-8") as f:
        f.write("".join(f"# {line}\n" for line in header.splitlines()))
        f.write(",".join(CSV_COLUMNS) + "\n")
        np.savetxt(f, table, delimiter=",", fmt="%.17g")


def _read_csv_metadata(lines: list[str], path: Path) -> tuple[float, dict, int]:
    sigma_e, attrs, start = 0.1, {}, 0
    for start, line in enumerate(lines):
        if not line.startswith("#"):
            break
        key, _, value = line[1:].strip().partition("=")
        try:
            if key == "sigma_e":
                sigma_e = float(value)
            elif key == "attrs":
                attrs = json.loads(value)
        except ValueError:
            raise ValueError(f"{path}: malformed metadata line {line.strip()!r}") from None
    return sigma_e, attrs, start


def _load_csv(path: Path) -> Measurements:
    lines = path.read_text(encoding="utf-8").splitlines()
    sigma_e, attrs, start = _read_csv_metadata(lines, path)
    if start >= len(lines):
        raise ValueError(f"{path}: no header line 'load,x,strain'")
    header = [h.strip().lower() for h in lines[start].split(",")]
    if sorted(header) != sorted(CSV_COLUMNS):
        raise ValueError(f"{path}: header must name the columns load, x, strain; got {lines[start]!r}")
    numbers = [j + 1 for j in range(start + 1, len(lines)) if lines[j].strip()]  # 1-based
    table = np.array([_csv_row(lines[j - 1], j, path) for j in numbers], dtype=np.float64)
    if table.shape[0] == 0:
        raise ValueError(f"{path}: no data rows after the header (expected load, x, strain)")
    cols = {name: table[:, header.index(name)] for name in CSV_COLUMNS}
    bad = ~np.isfinite(table).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        what = [name for name in CSV_COLUMNS if not np.isfinite(cols[name][i])]
        raise ValueError(
            f"{path}, line {numbers[i]}: {' and '.join(what)} is {cols[what[0]][i]} (load "
            f"{cols['load'][i]:g}, x = {cols['x'][i]:g} m); every value must be a finite number "
            f"({int(bad.sum())} such row(s))"
        )
    return _from_long(cols["load"], cols["x"], cols["strain"], sigma_e, attrs, path)


def _csv_row(line: str, number: int, path: Path) -> list[float]:
    """The 3 numbers of data line ``number`` (1-based); ``ValueError`` naming file and line."""
    fields = line.split(",")
    if len(fields) != 3:
        raise ValueError(
            f"{path}, line {number}: expected 3 values (load, x, strain), got {len(fields)}: "
            f"{line.strip()[:80]!r}"
        )
    try:
        return [float(v) for v in fields]
    except ValueError as err:
        raise ValueError(f"{path}, line {number}: malformed row ({err})") from None


def _from_long(
    load: np.ndarray, x: np.ndarray, strain: np.ndarray, sigma_e: float, attrs: dict, path: Path
) -> Measurements:
    """Grid the long table: loads in order of first appearance, positions sorted."""
    if not (np.all(np.isfinite(load)) and np.all(np.isfinite(x))):
        raise ValueError(f"{path}: a load or x value is NaN or inf")
    unique_loads, first, li = np.unique(load, return_index=True, return_inverse=True)
    appearance = np.argsort(first)  # position in first-appearance order of each sorted load
    rank = np.empty_like(appearance)
    rank[appearance] = np.arange(appearance.size)
    li = rank[li]
    xs, xi = np.unique(x, return_inverse=True)
    counts = np.bincount(li * xs.size + xi, minlength=unique_loads.size * xs.size)
    if counts.max() > 1:
        i = np.flatnonzero(li * xs.size + xi == np.argmax(counts))[0]
        raise ValueError(f"{path}: load {load[i]:g} at x = {x[i]:g} m appears more than once")
    if counts.min() == 0:
        i, j = divmod(int(np.argmin(counts)), xs.size)
        raise ValueError(f"{path}: no strain for load {unique_loads[appearance][i]:g} at x = {xs[j]:g} m")
    y = np.empty((unique_loads.size, xs.size))
    y[li, xi] = strain
    return Measurements(xs, y, unique_loads[appearance], sigma_e, attrs)


def _save_nc(m: Measurements, path: Path) -> None:
    import xarray as xr

    ds = xr.Dataset(
        {"strain": (("load", "x"), m.y, {"units": "microstrain"})},
        coords={"load": ("load", m.loads, {"units": "m"}), "x": ("x", m.x, {"units": "m"})},
        attrs={"sigma_e": m.sigma_e, "attrs": json.dumps(m.attrs, sort_keys=True),
               "format": "torchshm measurements"},
    )
    ds.to_netcdf(path, engine="h5netcdf")


def _load_nc(path: Path) -> Measurements:
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except Exception as err:  # noqa: BLE001 - any reader failure means a malformed file
        raise ValueError(f"{path}: not a readable netCDF file ({type(err).__name__}: {err})") from None
    if "strain" not in ds or ds["strain"].dims != ("load", "x"):
        raise ValueError(f"{path}: needs a variable 'strain' with dims (load, x)")
    try:
        attrs = json.loads(ds.attrs.get("attrs", "{}"))
    except ValueError:
        raise ValueError(f"{path}: malformed 'attrs' attribute") from None
    try:
        strain = np.asarray(ds["strain"].values, dtype=np.float64)
        x, load = (np.asarray(ds[c].values, dtype=np.float64) for c in ("x", "load"))
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: strain, load and x must be numeric ({err})") from None
    bad = np.argwhere(~np.isfinite(strain))
    if bad.size:
        i, j = (int(v) for v in bad[0])
        raise ValueError(
            f"{path}: strain is {strain[i, j]} at load {load[i]:g}, x = {x[j]:g} m (index "
            f"({i}, {j})); every value must be a finite number ({len(bad)} such value(s))"
        )
    return Measurements(x, strain, load, float(ds.attrs.get("sigma_e", 0.1)), attrs)


__all__ = ["save", "load"]
