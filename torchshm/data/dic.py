"""Image-correlation (DIC) strain fields: one export per image -> :class:`Measurements`.

Each image (one load case) is a table of subsets: coordinates, strain components and, in most
tools, a per-subset quality value that marks lost subsets. :func:`read_dic` reads one file per
load case (:mod:`torchshm.data.dic_table` parses each), takes the union of their points as the
field, sorted by x then y, and keeps every lost or absent subset as a masked reading
(``missing="mask"``), so a hole in one image costs nothing in the others.

Presets (``preset=``) name the columns of a tool's export; ``columns=`` overrides any of them:

- ``"dice"``: DICe's ``DICe_solution_<frame>.txt`` (``***`` header block, comma-separated):
  ``COORDINATE_X``, ``COORDINATE_Y`` [px], ``VSG_STRAIN_XX`` [-] and ``SIGMA`` (-1 for a
  subset that failed to correlate).
- ``"csv"``: a generic table with columns ``x``, ``y``, ``exx`` and no quality column; a
  ``nan`` or empty strain cell is a lost subset.

Units: coordinates are multiplied by ``scale`` [m per file unit: the pixel size in m for pixel
coordinates, 1e-3 for mm], after subtracting ``origin`` (file units); strains by
``strain_scale`` [µε per file unit: 1e6 for a strain in m/m, 1e4 for %].
"""

from __future__ import annotations

import glob
import re
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from torchshm.data.dic_table import read_table
from torchshm.data.formats import Format, register_format
from torchshm.data.measurements import Measurements

PRESETS: dict[str, dict[str, str | None]] = {
    "dice": {"x": "COORDINATE_X", "y": "COORDINATE_Y", "strain": "VSG_STRAIN_XX", "valid": "SIGMA"},
    "csv": {"x": "x", "y": "y", "strain": "exx", "valid": None},
}
ROUND_M = 1e-9  # coordinates [m] are rounded to this before points of two images are matched


def dic_files(path: str | Path | Sequence[str | Path]) -> list[Path]:
    """The files of a glob pattern (sorted by the numbers in their names), or the files given."""
    if isinstance(path, (str, Path)):
        if any(c in str(path) for c in "*?["):
            found = sorted(glob.glob(str(path)), key=_natural)
            if not found:
                raise FileNotFoundError(f"DIC files: nothing matches {path}")
            return [Path(p) for p in found]
        return [Path(path)]
    return [Path(p) for p in path]


def _natural(name: str) -> list[object]:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def read_dic(
    path: str | Path | Sequence[str | Path] | Mapping[float, str | Path],
    loads: Sequence[float] | None = None,
    *,
    preset: str = "dice",
    columns: Mapping[str, str | None] | None = None,
    valid_min: float = 0.0,
    scale: float = 1.0,
    origin: Sequence[float] = (0.0, 0.0),
    strain_scale: float = 1e6,
    every: int = 1,
    sigma_e: float = 0.1,
    attrs: Mapping[str, object] | None = None,
) -> Measurements:
    """The strain field of several images, one load case per image, lost subsets masked.

    Args:
        path: a mapping load case -> export; or exports (a list, or a glob pattern such as
            ``"solution/DICe_solution_*.txt"``, sorted by the numbers in the names) paired in
            order with ``loads``.
        loads: the load case of each export (with a list or pattern); one per file.
        preset: ``"dice"`` or ``"csv"`` (see the module); the column names of the export.
        columns: overrides of the preset's names: ``x``, ``y``, ``strain`` (a column name, or a
            list of names read as one sensor line each, labelled by the name) and ``valid``
            (a quality column, or ``None``).
        valid_min: a subset is valid where its ``valid`` column is >= this (DICe's and VIC's
            sigma is -1 for a lost subset; use 1 for a 0/1 validity column).
        scale: metres per coordinate unit (e.g. the pixel size in m).
        origin: the file coordinates ``(x0, y0)`` put at (0, 0) m.
        strain_scale: µε per strain unit of the file (1e6 for m/m, 1e4 for %).
        every: keep every ``every``-th distinct x and y value of the points (from the first):
            a grid thinned ``every`` times in each direction (1: every point).
        sigma_e, attrs: as for :class:`Measurements`.

    Returns:
        Measurements with `n x 2` coordinates [m] (the union of every image's points, sorted by
        x then y), `L x n` strains [µε], NaN and masked where a subset is lost or absent.

    Raises:
        ValueError: naming the file or option, for a malformed export, a load count that does
            not match the files, or an image with no valid subset.
    """
    if preset not in PRESETS:
        raise ValueError(f"read_dic: preset must be one of {sorted(PRESETS)}, got {preset!r}")
    names = dict(PRESETS[preset])
    unknown = set(columns or {}) - set(names)
    if unknown:
        raise ValueError(f"read_dic: unknown column role(s) {sorted(unknown)}; use x, y, strain, valid")
    names.update(columns or {})
    files = _pair(path, loads)
    strains = [names["strain"]] if isinstance(names["strain"], str) else list(names["strain"] or [])
    if not strains:
        raise ValueError("read_dic: name at least one strain column")
    wanted = [str(names["x"]), str(names["y"]), *strains] + ([str(names["valid"])] if names["valid"] else [])
    origin_xy = np.asarray(origin, dtype=np.float64).reshape(2)
    images = []
    for load, f in files.items():
        table = read_table(f, wanted)
        xy = (np.column_stack([table[wanted[0]], table[wanted[1]]]) - origin_xy) * float(scale)
        if not np.isfinite(xy).all():
            raise ValueError(f"{f}: a coordinate is empty or not finite")
        ok = np.ones(xy.shape[0], bool) if not names["valid"] else table[wanted[-1]] >= valid_min
        values = np.stack([np.where(ok, table[s] * strain_scale, np.nan) for s in strains])  # C x rows
        if not np.isfinite(values).any():
            raise ValueError(f"{f}: no valid subset (load {load:g}); check the 'valid' column and valid_min")
        images.append((np.round(xy / ROUND_M) * ROUND_M, values, f))
    if int(every) != every or every < 1:
        raise ValueError(f"read_dic: every must be a whole number >= 1, got {every!r}")
    return _assemble(images, list(files), strains, int(every), sigma_e, attrs)


def _pair(path: object, loads: Sequence[float] | None) -> dict[float, Path]:
    if isinstance(path, Mapping):
        if loads is not None:
            raise ValueError("read_dic: give loads with a list or pattern of files, not with a mapping")
        return {float(k): Path(v) for k, v in path.items()}
    files = dic_files(path)  # type: ignore[arg-type]
    if loads is None or len(loads) != len(files):
        got = "no loads" if loads is None else f"{len(loads)} load(s)"
        shown = ", ".join(p.name for p in files[:4]) + (", ..." if len(files) > 4 else "")
        raise ValueError(f"read_dic: {len(files)} file(s) ({shown}) but {got}; give one load case per file")
    return {float(v): f for v, f in zip(loads, files)}


def _assemble(images: list, loads: list[float], strains: list[str], every: int, sigma_e: float,
              attrs: Mapping[str, object] | None) -> Measurements:
    """One field: the union of the images' points, sorted by x then y; NaN where a point is absent."""
    points = np.unique(np.concatenate([xy for xy, _, _ in images]), axis=0)
    if every > 1:
        rank = [np.searchsorted(np.unique(points[:, a]), points[:, a]) for a in (0, 1)]
        points = points[(rank[0] % every == 0) & (rank[1] % every == 0)]
        images = [(xy[keep], values[:, keep], f) for xy, values, f in images
                  for keep in [np.isin(xy.view(complex).ravel(), points.view(complex).ravel())]]
    y = np.full((len(strains), len(loads), points.shape[0]), np.nan)
    for i, (xy, values, f) in enumerate(images):
        where = _rows_of(xy, points)
        if np.unique(where).size != where.size:
            raise ValueError(f"{f}: a point appears more than once")
        y[:, i, where] = values
    line = None if len(strains) == 1 else [s for s in strains for _ in range(points.shape[0])]
    x = np.tile(points, (len(strains), 1))
    meta = {"source": "image correlation", **dict(attrs or {})}
    return Measurements(x, np.concatenate(list(y), axis=1), loads, sigma_e, meta,  # type: ignore[arg-type]
                        line=line, missing="mask")


def _rows_of(xy: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Index into ``points`` (unique, sorted by x then y) of each row of ``xy`` (each one of them)."""
    lo = np.searchsorted(points[:, 0], xy[:, 0], side="left")
    hi = np.searchsorted(points[:, 0], xy[:, 0], side="right")
    out = np.empty(xy.shape[0], dtype=np.int64)
    for value in np.unique(xy[:, 0]):  # one column of the grid at a time
        rows = np.flatnonzero(xy[:, 0] == value)
        a, b = lo[rows[0]], hi[rows[0]]
        out[rows] = a + np.searchsorted(points[a:b, 1], xy[rows, 1])
    return out


__all__ = ["PRESETS", "dic_files", "read_dic"]


def _read(path: object, format: str | None, missing: str | None, **options: object) -> Measurements:
    """:func:`read_dic`, refusing a field with lost subsets when ``missing="error"``."""
    field = read_dic(path, **options)  # type: ignore[arg-type]
    if missing == "error" and field.n_missing:
        raise ValueError(f"load_measurements: {field.n_missing} lost or absent DIC subset(s); "
                         "use missing='mask'")
    return field


#: image-correlation exports (never chosen by suffix)
DIC = register_format(Format("dic", _read, options=True))
