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
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from torchshm.data.positions import POSITION_TOL, nearest_index

AttrValue = float | int | str


class Measurements:
    """Strains of `L` load cases at `n` positions.

    Args:
        x: `n` positions along the fibre [m], strictly increasing.
        y: `L x n` measured strains [µε], finite.
        loads: `L` load cases (front-axle positions [m]), no repeats.
        sigma_e: standard deviation of the independent measurement noise [µε], >= 0.
        attrs: metadata (numbers or strings), e.g. ``truth_E_c`` for a synthetic campaign.

    Raises:
        ValueError: naming the problem, for NaN or inf values, a shape mismatch, unsorted or
            repeated positions, repeated loads or a negative ``sigma_e``.
    """

    def __init__(
        self,
        x: Iterable[float],
        y: Iterable[Iterable[float]],
        loads: Iterable[float],
        sigma_e: float = 0.1,
        attrs: Mapping[str, AttrValue] | None = None,
    ) -> None:
        self.x = _as_array(x, "x", ndim=1)
        self.loads = _as_array(loads, "loads", ndim=1)
        self.y = _as_array(y, "y", ndim=2)
        if self.y.shape != (self.loads.size, self.x.size):
            raise ValueError(
                f"measurements: y has shape {self.y.shape}, expected (L, n) = "
                f"({self.loads.size}, {self.x.size}) from loads and x"
            )
        if self.x.size == 0 or self.loads.size == 0:
            raise ValueError("measurements: need at least one load case and one position")
        steps = np.diff(self.x)
        if np.any(steps == 0):
            raise ValueError(f"measurements: repeated position x = {self.x[1:][steps == 0][0]:g} m")
        if np.any(steps < 0):
            raise ValueError(f"measurements: positions x are not sorted (at x = {self.x[1:][steps < 0][0]:g} m)")
        _check_unique_loads(self.loads)
        sigma_e = float(sigma_e)
        if not np.isfinite(sigma_e) or sigma_e < 0:
            raise ValueError(f"measurements: sigma_e must be finite and >= 0, got {sigma_e}")
        self.sigma_e = sigma_e
        self.attrs: dict[str, AttrValue] = {
            str(k): v.item() if isinstance(v, np.generic) else v for k, v in (attrs or {}).items()
        }

    # ------------------------------------------------------------------ views
    @property
    def n(self) -> int:
        """Number of positions."""
        return int(self.x.size)

    @property
    def pitch(self) -> float | None:
        """Spacing of the positions [m] when they are equally spaced, else ``None``."""
        if self.x.size < 2:
            return None
        steps = np.diff(self.x)
        if np.ptp(steps) > POSITION_TOL:
            return None
        return float(np.round(steps.mean(), 9))

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
        return Measurements(self.x, self.y[index], self.loads[index], self.sigma_e, self.attrs)

    def downsample(self, resolution: float) -> Measurements:
        """Every k-th position from the first one, k = resolution / pitch (the paper's Sec. 6).

        Args:
            resolution: spacing of the kept positions [m], a whole multiple of :attr:`pitch`.
        """
        resolution = float(resolution)
        pitch = self.pitch
        if pitch is None:
            raise ValueError("measurements: cannot downsample, positions x are not equally spaced")
        ratio = resolution / pitch
        k = int(round(ratio)) if np.isfinite(ratio) else 0
        if k < 1 or abs(ratio - k) > 1e-6:
            raise ValueError(
                f"resolution {resolution:g} m is not a whole multiple of the pitch {pitch:g} m"
            )
        return Measurements(self.x[::k], self.y[:, ::k], self.loads, self.sigma_e, self.attrs)

    def equals(self, other: Measurements) -> bool:
        """Exact equality of values and metadata."""
        return (
            np.array_equal(self.x, other.x)
            and np.array_equal(self.y, other.y)
            and np.array_equal(self.loads, other.loads)
            and self.sigma_e == other.sigma_e
            and self.attrs == other.attrs
        )

    def __repr__(self) -> str:
        pitch = self.pitch
        spacing = f"pitch {pitch:g} m" if pitch is not None else "irregular"
        loads = ", ".join(f"{v:g}" for v in self.loads)
        return (
            f"Measurements({self.loads.size} load cases [{loads}], {self.n} positions "
            f"{self.x[0]:g}..{self.x[-1]:g} m, {spacing}, sigma_e={self.sigma_e:g} µε)"
        )

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        """Write to ``.csv`` (long format) or ``.nc`` (netCDF-4); returns the path."""
        from torchshm.data import io

        return io.save(self, Path(path))


def load_measurements(path: str | Path) -> Measurements:
    """Read measurements from a ``.csv`` (long format ``load,x,strain``) or ``.nc`` file.

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: naming the problem, for a malformed file or invalid values.
    """
    from torchshm.data import io

    return io.load(Path(path))


def _as_array(values: object, name: str, ndim: int) -> np.ndarray:
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(f"measurements: {name} is not numeric ({err})") from None
    if array.ndim != ndim:
        raise ValueError(f"measurements: {name} must be {ndim}-D, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"measurements: {name} has a NaN or inf value at index {tuple(int(i) for i in bad)}")
    return array


def _check_unique_loads(loads: np.ndarray) -> None:
    order = np.sort(loads)
    repeated = np.flatnonzero(np.diff(order) <= POSITION_TOL)
    if repeated.size:
        raise ValueError(f"measurements: repeated load case {order[repeated[0]]:g}")
