"""Strain measurements along a fibre for several load cases.

A :class:`Measurements` holds `L` load cases (each identified by the truck's front-axle position
in m) measured at the same `n` positions `x` along the fibre [m], strains in µε. It is validated
on construction, so a bad file or array is reported once, with a message that names the problem,
instead of surfacing later as a NaN likelihood.

Two file formats, chosen by suffix:

- ``.csv``: long format, one row per reading with columns ``load,x,strain``; metadata
  (``sigma_e`` and ``attrs``) in leading ``# key=value`` comment lines. Numbers are written with
  17 significant digits, so a round trip is exact.
- ``.nc``: netCDF-4 (through xarray and h5netcdf) with variable ``strain`` on dims
  ``(load, x)`` and the metadata as attributes.

Several sensor lines (``line``), 2-D/3-D coordinates and masked dropouts (``missing="mask"``)
are written in the extended layouts of :mod:`torchshm.data.tables`; a Luna ODiSI ``.tsv``
export is read by :mod:`torchshm.data.odisi`. See ``docs/measurements.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from torchshm.data import lines as _lines
from torchshm.data.formats import write_measurements
from torchshm.data.positions import POSITION_TOL, nearest_index

AttrValue = float | int | str


class Measurements:
    """Strains of `L` load cases at `n` positions, on one or several sensor lines.

    Args:
        x: `n` positions along the fibre [m] (strictly increasing within each line), or
            `n x d` coordinates [m] of a field (d = 2, 3; no repeated point within a line).
        y: `L x n` measured strains [µε]; finite, except NaN dropouts when ``missing="mask"``.
        loads: `L` load cases (front-axle positions [m]), no repeats.
        sigma_e: standard deviation of the independent measurement noise [µε], >= 0; or a dict
            line label -> level, one per line.
        attrs: metadata (numbers or strings), e.g. ``truth_E_c`` for a synthetic campaign.
        line: ``None`` (one fibre) or `n` labels (all int or all str); the points of a line are
            contiguous and the same x may appear on two lines.
        missing: ``"error"`` refuses NaN in ``y``; ``"mask"`` keeps each NaN as a dropout of its
            own load case (:attr:`mask`, :attr:`n_missing`). inf is always refused.

    Raises:
        ValueError: naming the problem, for NaN or inf values, a shape mismatch, unsorted or
            repeated positions, repeated loads, bad line labels or a negative ``sigma_e``.
    """

    def __init__(
        self,
        x: Iterable[float],
        y: Iterable[Iterable[float]],
        loads: Iterable[float],
        sigma_e: float | Mapping[object, float] = 0.1,
        attrs: Mapping[str, AttrValue] | None = None,
        *,
        line: Iterable[int | str] | None = None,
        missing: str = "error",
    ) -> None:
        if missing not in ("error", "mask"):
            raise ValueError(f"measurements: missing must be 'error' or 'mask', got {missing!r}")
        self.missing = missing
        self.x = _as_array(x, "x", ndim=(1, 2))
        if self.x.ndim == 2 and self.x.shape[1] not in (2, 3):
            raise ValueError(f"measurements: x of shape {self.x.shape} must be (n,) or (n, d) with d = 2 or 3")
        self.loads = _as_array(loads, "loads", ndim=1)
        self.y = _as_array(y, "y", ndim=2, allow_nan=True)
        n = self.x.shape[0]
        if self.y.shape != (self.loads.size, n):
            raise ValueError(
                f"measurements: y has shape {self.y.shape}, expected (L, n) = "
                f"({self.loads.size}, {n}) from loads and x"
            )
        if n == 0 or self.loads.size == 0:
            raise ValueError("measurements: need at least one load case and one position")
        self.line = _lines.as_labels(line, n)
        self._blocks = _lines.blocks(self.line, n)
        _lines.check_positions(self.x, self._blocks)
        _check_unique_loads(self.loads)
        self.mask = ~np.isnan(self.y)
        self._check_missing()
        self.sigma_e = _lines.sigma_by_line(sigma_e, self._blocks)
        self.attrs: dict[str, AttrValue] = {
            str(k): v.item() if isinstance(v, np.generic) else v for k, v in (attrs or {}).items()
        }

    def _check_missing(self) -> None:
        """NaN refused with ``missing="error"``; a load case with no valid reading always."""
        bad = np.argwhere(~self.mask)
        if bad.size and self.missing == "error":
            i, j = (int(v) for v in bad[0])
            raise ValueError(
                f"measurements: y has {len(bad)} NaN or inf value(s), first at load {self.loads[i]:g}, "
                f"{self._where(j)} (index ({i}, {j})); missing='mask' treats NaN readings as dropouts"
            )
        empty = np.flatnonzero(~self.mask.any(axis=1))
        if empty.size:
            raise ValueError(f"measurements: load case {self.loads[empty[0]]:g} has no valid reading")

    def _where(self, j: int) -> str:
        place = f"x = {self.x[j]:g} m" if self.x.ndim == 1 else f"x = {tuple(float(v) for v in self.x[j])} m"
        return place + ("" if self.line is None else f" on line {_lines.label_of(self.line[j])!r}")

    # ------------------------------------------------------------------ views
    @property
    def n(self) -> int:
        """Number of positions."""
        return int(self.x.shape[0])

    @property
    def n_missing(self) -> int:
        """Number of masked (NaN) readings over all load cases."""
        return int((~self.mask).sum())

    @property
    def lines(self) -> tuple:
        """Line labels in order (``(None,)`` for one unnamed line)."""
        return tuple(self._blocks)

    def line_slices(self) -> dict:
        """Line label -> slice of its positions (``{None: slice(0, n)}`` for one unnamed line)."""
        return dict(self._blocks)

    def sigma_e_of(self, label: object) -> float:
        """The noise level [µε] of line `label`."""
        return self.sigma_e[label] if isinstance(self.sigma_e, dict) else self.sigma_e

    @property
    def pitch(self) -> float | None:
        """Spacing of the positions [m] when every line is equally spaced at one pitch, else ``None``."""
        pitches = {_lines.pitch_of(self.x[s], POSITION_TOL) for s in self._blocks.values()}
        return pitches.pop() if len(pitches) == 1 else None

    def load_index(self, loads: Iterable[float]) -> np.ndarray:
        """Indices of `loads` in :attr:`loads` (within 1e-6 m); ValueError naming an unknown one."""
        try:
            wanted = np.atleast_1d(np.asarray(loads, dtype=np.float64)).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError(f"load cases must be numbers, got {loads!r}") from None
        index, found = nearest_index(wanted, self.loads)
        if not found.all():
            known = ", ".join(f"{v:g}" for v in self.loads)
            raise ValueError(
                f"unknown load case {wanted[~found][0]:g} (measured load cases: {known})"
            )
        return index.astype(np.int64)

    def select(self, loads: Iterable[float] | float) -> Measurements:
        """The load cases `loads` (front-axle positions [m]), in the order given."""
        index = self.load_index(loads)  # type: ignore[arg-type]
        return self._with(self.y[index], self.loads[index], slice(None))

    def _with(self, y: np.ndarray, loads: np.ndarray, points: slice | np.ndarray) -> Measurements:
        line = None if self.line is None else self.line[points]
        return Measurements(self.x[points], y, loads, self.sigma_e, self.attrs, line=line, missing=self.missing)

    def downsample(self, resolution: float) -> Measurements:
        """Every k-th position from the first one of each line, k = resolution / pitch (Sec. 6).

        Args:
            resolution: spacing of the kept positions [m], a whole multiple of each line's pitch.

        Raises:
            ValueError: for a 2-D/3-D field, unequally spaced positions or a resolution that is
                not a whole multiple of a line's pitch.
        """
        points = _lines.downsample_index(self.x, self._blocks, float(resolution), POSITION_TOL)
        return self._with(self.y[:, points], self.loads, points)

    def equals(self, other: Measurements) -> bool:
        """Exact equality of values and metadata."""
        same_line = (self.line is None and other.line is None) or (
            self.line is not None and other.line is not None
            and self.line.dtype.kind == other.line.dtype.kind and np.array_equal(self.line, other.line)
        )
        return (
            self.x.shape == other.x.shape
            and np.array_equal(self.x, other.x)
            and np.array_equal(self.y, other.y, equal_nan=True)
            and np.array_equal(self.loads, other.loads)
            and same_line
            and self.missing == other.missing
            and self.sigma_e == other.sigma_e
            and self.attrs == other.attrs
        )

    def __repr__(self) -> str:
        loads = ", ".join(f"{v:g}" for v in self.loads)
        if self.x.ndim == 1:
            pitch = self.pitch
            spacing = f"pitch {pitch:g} m" if pitch is not None else "irregular"
            where = f"{self.x.min():g}..{self.x.max():g} m, {spacing}"
        else:
            where = f"{self.x.shape[1]}-D field"
        sigma = (
            f"sigma_e={self.sigma_e:g} µε" if not isinstance(self.sigma_e, dict)
            else "sigma_e={" + ", ".join(f"{k!r}: {v:g}" for k, v in self.sigma_e.items()) + "} µε"
        )
        extra = "" if self.line is None else f", {len(self._blocks)} lines [{', '.join(map(str, self._blocks))}]"
        if self.missing == "mask":
            extra += f", {self.n_missing} missing (masked)"
        return (
            f"Measurements({self.loads.size} load cases [{loads}], {self.n} positions "
            f"{where}{extra}, {sigma})"
        )

    def summary(self) -> str:
        """Several lines: per sensor line its points, range, pitch, noise and masked readings."""
        out = [repr(self)]
        for label, s in self._blocks.items():
            xs, masked = self.x[s], int((~self.mask[:, s]).sum())
            pitch = _lines.pitch_of(xs, POSITION_TOL)
            span = f"{xs.min():g}..{xs.max():g} m" if xs.ndim == 1 else f"{xs.shape[1]}-D points"
            out.append(
                f"  line {label!r}: {s.stop - s.start} positions {span}, "
                f"{'pitch %g m' % pitch if pitch else 'irregular'}, sigma_e={self.sigma_e_of(label):g} µε, "
                f"{masked} of {self.loads.size * (s.stop - s.start)} readings missing"
            )
        return "\n".join(out)

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        """Write to ``.csv`` (long format) or ``.nc`` (netCDF-4); returns the path.

        One fibre with no NaN and 1-D positions is written in the original layout; several lines,
        coordinates, masked readings or per-line noise in the extended one (:mod:`~torchshm.data.tables`);
        the writer is the registered format of the suffix (:mod:`torchshm.data.formats`).
        """
        return write_measurements(self, path)


def _as_array(values: object, name: str, ndim: int | tuple[int, ...], allow_nan: bool = False) -> np.ndarray:
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(f"measurements: {name} is not numeric ({err})") from None
    dims = (ndim,) if isinstance(ndim, int) else ndim
    if array.ndim not in dims:
        shown = " or ".join(f"{d}-D" for d in dims)
        raise ValueError(f"measurements: {name} must be {shown}, got shape {array.shape}")
    if allow_nan and np.all(np.isfinite(array) | np.isnan(array)):
        return array
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"measurements: {name} has a NaN or inf value at index {tuple(int(i) for i in bad)}")
    return array


def _check_unique_loads(loads: np.ndarray) -> None:
    order = np.sort(loads)
    repeated = np.flatnonzero(np.diff(order) <= POSITION_TOL)
    if repeated.size:
        raise ValueError(f"measurements: repeated load case {order[repeated[0]]:g}")
