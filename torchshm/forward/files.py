"""The file contract between :class:`ExternalModel` and an external FE program.

In: ``params.json`` = ``{"theta_p": [...], "names": [...], "loads": [...], "x": [...]}``
(physical parameters in model order and units, their names, the load cases [m] and sensor
positions [m] the program must report). Out: strains [µε] for every load case and sensor, as

* NPZ: array ``strain`` of shape `L x n` (rows in the order of ``loads``, columns in the order
  of ``x``), optionally arrays ``x`` and ``loads``, which are then checked; or
* CSV: a header ``load,x,strain`` and one row per (load case, position), in any order.

See ``docs/external_models.md``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from torchshm.data.positions import POSITION_TOL as POSITION_TOLERANCE
from torchshm.data.positions import nearest_index

PARAMS_FILE = "params.json"
LOG_FILE = "run.log"


def write_params(
    path: Path, theta_p: np.ndarray, names: Sequence[str], x: np.ndarray, loads: np.ndarray
) -> None:
    """Write ``params.json`` for one run (θp `P`, names `P`, x `n` [m], loads `L` [m])."""
    content = {
        "theta_p": [float(v) for v in theta_p], "names": list(names),
        "loads": [float(v) for v in loads], "x": [float(v) for v in x],
    }
    path.write_text(json.dumps(content, indent=1))


def read_params(path: str | Path = PARAMS_FILE) -> dict[str, object]:
    """Read ``params.json`` (for programs written in Python)."""
    return json.loads(Path(path).read_text())


def write_strains(
    path: str | Path, strain: np.ndarray, x: np.ndarray | None = None,
    loads: np.ndarray | None = None,
) -> None:
    """Write strains `L x n` [µε] in the format given by the suffix (``.npz`` or ``.csv``)."""
    path, strain = Path(path), np.asarray(strain, dtype=np.float64)
    if path.suffix == ".npz":
        arrays = {"strain": strain}
        arrays.update({k: np.asarray(v) for k, v in (("x", x), ("loads", loads)) if v is not None})
        np.savez(path, **arrays)
    elif path.suffix == ".csv":
        if x is None or loads is None:
            raise ValueError("a CSV strain file needs x and loads")
        lines = ["load,x,strain"] + [
            f"{float(load)!r},{float(pos)!r},{float(value)!r}"
            for load, row in zip(loads, strain) for pos, value in zip(x, row)
        ]
        path.write_text("\n".join(lines) + "\n")
    else:
        raise ValueError(f"strain file {path.name}: unknown format, use .npz or .csv")


def read_strains(path: str | Path, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """Read the strains a program wrote and check them against the model's x and loads.

    Args:
        path: an ``.npz`` or ``.csv`` file following the contract above.
        x: the model's sensor positions `n` [m].
        loads: the model's load cases `L` [m].

    Returns:
        Strains [µε] `L x n`, float64.

    Raises:
        ValueError: if the file is missing, unreadable, has a wrong shape, positions or load
            cases that do not match, or NaN/inf values; the message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no strain file {path.name} was written")
    if path.suffix == ".npz":
        strain = _read_npz(path, x, loads)
    elif path.suffix == ".csv":
        strain = _read_csv(path, x, loads)
    else:
        raise ValueError(f"strain file {path.name}: unknown format, use .npz or .csv")
    if not np.isfinite(strain).all():
        raise ValueError(f"{path.name}: {int((~np.isfinite(strain)).sum())} strains are NaN or inf")
    return strain


def _read_npz(path: Path, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: np.asarray(data[name], dtype=np.float64) for name in data.files}
    except Exception as exc:  # numpy raises many types for a damaged file
        raise ValueError(f"{path.name} is not a readable NPZ file: {exc}") from None
    if "strain" not in arrays:
        raise ValueError(f"{path.name} has no array 'strain' (found {sorted(arrays)})")
    strain = arrays["strain"]
    if strain.shape != (len(loads), len(x)):
        raise ValueError(
            f"{path.name}: 'strain' has shape {strain.shape}, expected (L, n) = "
            f"{(len(loads), len(x))}"
        )
    for name, expected in (("x", x), ("loads", loads)):
        if name in arrays:
            given = arrays[name]
            if given.shape != expected.shape or not np.allclose(
                given, expected, rtol=0.0, atol=POSITION_TOLERANCE
            ):
                raise ValueError(f"{path.name}: '{name}' differs from the model's {name}")
    return strain


def _read_csv(path: Path, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
    try:
        with open(path, encoding="utf-8-sig") as handle:
            header = [column.strip().lower() for column in handle.readline().split(",")]
            table = np.loadtxt(handle, delimiter=",", dtype=np.float64, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path.name} is not a readable CSV file: {exc}") from None
    if header != ["load", "x", "strain"]:
        raise ValueError(f"{path.name}: header must be 'load,x,strain', got {','.join(header)!r}")
    if table.size and table.shape[1] != 3:
        raise ValueError(f"{path.name}: rows must have 3 columns, got {table.shape[1]}")
    table = table.reshape(-1, 3)
    rows = _match(table[:, 0], loads, path.name, "load")
    columns = _match(table[:, 1], x, path.name, "x")
    strain = np.full((len(loads), len(x)), np.nan)
    filled = np.zeros(strain.shape, dtype=int)
    np.add.at(filled, (rows, columns), 1)
    if (filled > 1).any():
        i, j = np.argwhere(filled > 1)[0]
        raise ValueError(f"{path.name}: repeated row for load {loads[i]:g}, x {x[j]:g}")
    if (filled == 0).any():
        i, j = np.argwhere(filled == 0)[0]
        raise ValueError(
            f"{path.name}: {int((filled == 0).sum())} of {filled.size} (load, x) pairs missing, "
            f"e.g. load {loads[i]:g}, x {x[j]:g}"
        )
    strain[rows, columns] = table[:, 2]
    return strain


def _match(values: np.ndarray, reference: np.ndarray, name: str, what: str) -> np.ndarray:
    """Index into ``reference`` of each value (:func:`~torchshm.data.positions.nearest_index`)."""
    if not np.isfinite(values).all():
        raise ValueError(f"{name}: a {what} value is NaN or inf")
    index, found = nearest_index(values, reference)
    if not found.all():
        raise ValueError(
            f"{name}: {what} {values[~found][0]:g} matches none of the model's {what} values"
        )
    return index
