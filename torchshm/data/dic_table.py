"""Parsing one image-correlation (DIC) export: a text table of points, one row per subset.

Every tool this reads writes, per image, a text table whose header row names the columns and
whose rows are the subsets (points) of the grid; lines before the header are metadata (DICe's
``***`` block, a title, units). The header row is found as the first line that names the
coordinate columns; the delimiter (``,``, ``;``, tab or blanks) is taken from that line.
Column names are matched without case, quotes or surrounding blanks, and also without a unit
suffix in brackets (``"x [mm]"`` matches ``x``). A ``.gz`` file is read decompressed.
"""

from __future__ import annotations

import gzip
import io
import re
from pathlib import Path

import numpy as np

HEADER_SEARCH = 400  # lines searched for the header row


def _open_text(path: Path) -> str:
    raw = path.read_bytes()
    if path.suffix.lower() == ".gz":
        raw = gzip.decompress(raw)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def normalise(name: str) -> str:
    """A column name without quotes, blanks, case and a bracketed unit: ``'"Exx [%]"' -> 'exx'``."""
    name = name.strip().strip("\"'").strip()
    name = re.sub(r"\s*[\[(].*[\])]\s*$", "", name)
    return name.lower()


def _split(line: str) -> tuple[list[str], str | None]:
    """Cells of ``line`` and the delimiter (``None``: blanks)."""
    for sep in (",", ";", "\t"):
        if sep in line:
            return [c.strip() for c in line.split(sep)], sep
    return line.split(), None


def read_table(path: str | Path, wanted: list[str]) -> dict[str, np.ndarray]:
    """The columns ``wanted`` (names as written by the tool) of one export, as float arrays.

    Args:
        path: the export (``.txt``, ``.csv``, ``.dat``; ``.gz`` compressed too).
        wanted: column names; an empty cell or ``nan`` reads as NaN.

    Returns:
        name -> `n_rows` values, in the file's row order.

    Raises:
        FileNotFoundError: no such file.
        ValueError: naming the file, for no header row naming the columns, a missing column or a
            cell that is not a number.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"DIC file not found: {path}")
    text = _open_text(path)
    lines = text.splitlines()
    keys = [normalise(w) for w in wanted]
    start = None
    for k, line in enumerate(lines[:HEADER_SEARCH]):
        cells, sep = _split(line)
        names = [normalise(c) for c in cells]
        if keys[0] in names and keys[1] in names:
            start = k
            break
    if start is None:
        raise ValueError(
            f"{path}: no header row naming the columns {wanted[0]!r} and {wanted[1]!r} in its first "
            f"{HEADER_SEARCH} lines (set the column names of your tool's export)"
        )
    missing = [w for w, key in zip(wanted, keys) if key not in names]
    if missing:
        shown = ", ".join(c.strip().strip("\"'") for c in cells)
        raise ValueError(f"{path}, line {start + 1}: no column {missing[0]!r} among {shown}")
    index = [names.index(key) for key in keys]
    body = "\n".join(line for line in lines[start + 1:] if line.strip())
    if not body:
        raise ValueError(f"{path}: no data rows after the header (line {start + 1})")
    import pandas as pd

    try:
        frame = pd.read_csv(io.StringIO(body), sep=sep or r"\s+", header=None, usecols=index,
                            skipinitialspace=True, dtype=str, keep_default_na=False, engine="c" if sep else "python")
        table = frame[index].apply(lambda c: c.str.strip().str.strip("\"'").replace("", "nan").astype(np.float64)) \
            .to_numpy(dtype=np.float64)
    except ValueError as err:
        raise ValueError(f"{path}: a row after line {start + 1} is malformed ({err})") from None
    if np.isinf(table).any():
        row = int(np.argwhere(np.isinf(table))[0][0])
        raise ValueError(f"{path}: an infinite value in data row {row + 1}")
    return {w: table[:, c] for c, w in enumerate(wanted)}


__all__ = ["normalise", "read_table"]
