"""Reading the strain files external programs write (NPZ and long-format CSV)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm.forward import read_strains, write_strains

X = np.array([0.0, 0.1, 0.2, 0.30000000000000004])
LOADS = np.array([9.8, 39.8])
STRAIN = np.arange(8.0).reshape(2, 4) / 7.0


@pytest.mark.parametrize("name", ["s.npz", "s.csv"])
def test_round_trip_is_exact(tmp_path: Path, name: str) -> None:
    write_strains(tmp_path / name, STRAIN, X, LOADS)
    assert np.array_equal(read_strains(tmp_path / name, X, LOADS), STRAIN)


def test_csv_in_any_order_with_rounded_positions(tmp_path: Path) -> None:
    rows = [f"{load:.1f},{x:.3f},{float(STRAIN[i, j])!r}" for i, load in enumerate(LOADS)
            for j, x in enumerate(X)][::-1]
    (tmp_path / "s.csv").write_text("load, x, strain\n" + "\n".join(rows) + "\n")
    assert np.array_equal(read_strains(tmp_path / "s.csv", X, LOADS), STRAIN)


def _csv(tmp_path: Path, lines: list[str]) -> Path:
    path = tmp_path / "s.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_errors(tmp_path: Path) -> None:
    full = [f"{load!r},{x!r},1.0" for load in LOADS.tolist() for x in X.tolist()]
    cases = [
        (["load,x,strain", *full[:-1]], r"1 of 8 \(load, x\) pairs missing, e.g. load 39.8, x 0.3"),
        (["load,x,strain", *full, full[0]], "repeated row for load 9.8, x 0"),
        (["position,strain", *full], "header must be 'load,x,strain'"),
        (["load,x,strain", *full[:-1], "39.8,0.35,1.0"], "x 0.35 matches none of the model's x"),
        (["load,x,strain", *full[:-1], "39.8,0.3,nan"], "1 strains are NaN or inf"),
        (["load,x,strain", *full[:-1], "39.8,0.3,abc"], "s.csv is not a readable CSV file"),
    ]
    for lines, message in cases:
        with pytest.raises(ValueError, match=message):
            read_strains(_csv(tmp_path, lines), X, LOADS)


def test_npz_errors(tmp_path: Path) -> None:
    path = tmp_path / "s.npz"
    np.savez(path, strains=STRAIN)
    with pytest.raises(ValueError, match=r"has no array 'strain' \(found \['strains'\]\)"):
        read_strains(path, X, LOADS)
    np.savez(path, strain=STRAIN, x=X + 0.01)
    with pytest.raises(ValueError, match="'x' differs from the model's x"):
        read_strains(path, X, LOADS)
    np.savez(path, strain=STRAIN.T)
    expected = r"'strain' has shape \(4, 2\), expected \(L, n\) = \(2, 4\)"
    with pytest.raises(ValueError, match=expected):
        read_strains(path, X, LOADS)
    with pytest.raises(ValueError, match="no strain file missing.npz was written"):
        read_strains(tmp_path / "missing.npz", X, LOADS)
