"""Sensor lines of a :class:`~torchshm.data.Measurements`: labels, blocks, positions, noise.

A campaign may hold several fibres ("lines"), each with its own positions along its own line.
The points of one line are contiguous in ``x`` and sorted along it (1-D arc length), so every
line is one slice of the position axis; the same ``x`` may appear on two lines. With ``line=None``
there is one unnamed line (label ``None``) and every rule is today's single-fibre rule.
"""

from __future__ import annotations

from typing import Hashable, Mapping

import numpy as np

Label = Hashable  # a line label: int or str (None for the one unnamed line)

_FORBIDDEN = (",", "\n", "\r", "\t", "#")


def as_labels(line: object, n: int) -> np.ndarray | None:
    """Validate line labels: `n` ints or `n` non-empty strings; ``None`` stays ``None``.

    Raises:
        ValueError: naming the problem (length, mixed types, an empty or unwritable string).
    """
    if line is None:
        return None
    values = list(np.asarray(line, dtype=object).reshape(-1)) if not isinstance(line, str) else [line]
    if len(values) != n:
        raise ValueError(f"measurements: line has {len(values)} labels, expected one per position ({n})")
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in values):
        return np.array(values, dtype=np.int64)
    if not all(isinstance(v, (str, np.str_)) for v in values):
        bad = next(v for v in values if not isinstance(v, (str, np.str_)))
        raise ValueError(f"measurements: line labels must be all int or all str, got {bad!r}")
    for v in values:
        if not v or v != v.strip() or any(c in v for c in _FORBIDDEN):
            raise ValueError(
                f"measurements: line label {v!r} must be non-empty, without surrounding spaces, "
                "commas, tabs, newlines or '#'"
            )
    return np.array([str(v) for v in values])


def label_of(value: object) -> Label:
    """A plain Python label (``int`` or ``str``) from a numpy scalar."""
    return value.item() if isinstance(value, np.generic) else value


def blocks(line: np.ndarray | None, n: int) -> dict[Label, slice]:
    """Label -> slice of the positions of each line, in order of appearance.

    Raises:
        ValueError: if a line's points are not contiguous.
    """
    if line is None:
        return {None: slice(0, n)}
    change = np.flatnonzero(line[1:] != line[:-1]) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [n]])
    out: dict[Label, slice] = {}
    for a, b in zip(starts, ends):
        label = label_of(line[a])
        if label in out:
            raise ValueError(
                f"measurements: the points of line {label!r} are not contiguous (again at index {a}); "
                "give each line's points together"
            )
        out[label] = slice(int(a), int(b))
    return out


def where(label: Label) -> str:
    """`` on line 'top'`` for messages (empty for the unnamed line)."""
    return "" if label is None else f" on line {label!r}"


def check_positions(x: np.ndarray, parts: Mapping[Label, slice]) -> None:
    """Positions sorted and unique within each line (1-D), or unique points (d-D).

    Raises:
        ValueError: naming the repeated or unsorted position and its line.
    """
    for label, s in parts.items():
        xs = x[s]
        if x.ndim == 1:
            steps = np.diff(xs)
            if np.any(steps == 0):
                raise ValueError(f"measurements: repeated position x = {xs[1:][steps == 0][0]:g} m{where(label)}")
            if np.any(steps < 0):
                raise ValueError(
                    f"measurements: positions x are not sorted (at x = {xs[1:][steps < 0][0]:g} m{where(label)})"
                )
        else:
            unique = np.unique(xs, axis=0)
            if unique.shape[0] != xs.shape[0]:
                raise ValueError(f"measurements: a repeated point in x{where(label)}")


def sigma_by_line(sigma_e: object, parts: Mapping[Label, slice]) -> float | dict[Label, float]:
    """A noise level [µε] >= 0, or a dict line -> level covering exactly the lines."""
    if isinstance(sigma_e, Mapping):
        if list(parts) == [None]:
            raise ValueError("measurements: sigma_e per line needs line labels (line=...)")
        given = {label_of(k): v for k, v in sigma_e.items()}
        if set(given) != set(parts):
            raise ValueError(
                f"measurements: sigma_e names lines {sorted(map(str, given))}, the data have "
                f"{sorted(map(str, parts))}"
            )
        return {label: _level(given[label], f"sigma_e[{label!r}]") for label in parts}
    return _level(sigma_e, "sigma_e")


def _level(value: object, name: str) -> float:
    try:
        level = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"measurements: {name} must be a number, got {value!r}") from None
    if not np.isfinite(level) or level < 0:
        raise ValueError(f"measurements: {name} must be finite and >= 0, got {level}")
    return level


def pitch_of(x: np.ndarray, tol: float) -> float | None:
    """Spacing [m] of sorted 1-D positions when equal within `tol`, else ``None``."""
    if x.ndim != 1 or x.size < 2:
        return None
    steps = np.diff(x)
    if np.ptp(steps) > tol:
        return None
    return float(np.round(steps.mean(), 9))


def downsample_index(x: np.ndarray, parts: Mapping[Label, slice], resolution: float, tol: float) -> np.ndarray:
    """Indices of every k-th point of each line from its first one, k = resolution / its pitch."""
    if x.ndim != 1:
        raise ValueError("measurements: cannot downsample a field given by coordinates (x is (n, d))")
    keep = []
    for label, s in parts.items():
        if s.stop - s.start == 1:
            keep.append(np.arange(s.start, s.stop))
            continue
        pitch = pitch_of(x[s], tol)
        if pitch is None:
            raise ValueError(
                f"measurements: cannot downsample, positions x are not equally spaced{where(label)}"
            )
        ratio = resolution / pitch
        k = int(round(ratio)) if np.isfinite(ratio) and np.isfinite(resolution) and resolution > 0 else 0
        if k < 1 or abs(ratio - k) > 1e-6:
            raise ValueError(
                f"resolution {resolution:g} m is not a whole multiple of the pitch {pitch:g} m"
                f"{where(label)}"
            )
        keep.append(np.arange(s.start, s.stop)[::k])
    return np.concatenate(keep)
