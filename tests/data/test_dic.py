"""Image-correlation exports -> Measurements: DICe solution files and a generic CSV."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

import torchshm
from torchshm.data.dic import read_dic

DICE_HEAD = """***
*** Digital Image Correlation Engine (DICe), Copyright 2015 National Technology & Engineering Solutions of Sandia, LLC (NTESS)
***
*** Reference image: ref.tif
*** Deformed image: def_{k}.tif
*** DIC method : local
*** Subset size: 21
*** Step size: x 10 y 10
***
SUBSET_ID,COORDINATE_X,COORDINATE_Y,DISPLACEMENT_X,DISPLACEMENT_Y,SIGMA,GAMMA,BETA,STATUS_FLAG,UNCERTAINTY,VSG_STRAIN_XX,VSG_STRAIN_YY,VSG_STRAIN_XY
"""

#: a 3 x 2 grid of subsets [px]; rows in DICe's order (row by row in the image)
GRID = [(100, 50), (110, 50), (120, 50), (100, 60), (110, 60), (120, 60)]


def write_dice(path: Path, k: int, exx: list[float], lost: set[int], gz: bool = False) -> Path:
    lines = [DICE_HEAD.format(k=k).rstrip("\n")]
    for i, ((cx, cy), e) in enumerate(zip(GRID, exx)):
        sigma = -1.0 if i in lost else 0.004
        flag = 11 if i in lost else 4
        lines.append(f"{i},{cx:.4E},{cy:.4E},1.2E-01,-3.0E-02,{sigma:.4E},1.0E-02,0.0E+00,{flag},7.0E-03,"
                     f"{e:.4E},{-0.3 * e:.4E},{0.1 * e:.4E}")
    text = "\n".join(lines) + "\n"
    if gz:
        path = path.with_suffix(path.suffix + ".gz")
        path.write_bytes(gzip.compress(text.encode()))
    else:
        path.write_text(text)
    return path


@pytest.fixture
def dice_files(tmp_path: Path) -> list[Path]:
    strains = [[1e-4 * (i + 1) for i in range(6)], [-2e-4 * (i + 1) for i in range(6)]]
    return [write_dice(tmp_path / f"DICe_solution_{k}.txt", k, strains[k], lost={1} if k == 0 else {4, 5},
                       gz=k == 1) for k in range(2)]


def test_dice_files_give_masked_field(dice_files: list[Path]) -> None:
    m = read_dic({0.5: dice_files[0], 1.0: dice_files[1]}, scale=1e-3, origin=(100, 50), sigma_e=20.0)
    # points sorted by x then y [m], from the pixel coordinates minus the origin
    np.testing.assert_allclose(m.x, [[0, 0], [0, 0.01], [0.01, 0], [0.01, 0.01], [0.02, 0], [0.02, 0.01]], atol=1e-12)
    file_row = [0, 3, 1, 4, 2, 5]  # the row of each sorted point in the files
    expected = np.array([[1e-4 * (r + 1) * 1e6 for r in file_row], [-2e-4 * (r + 1) * 1e6 for r in file_row]])
    expected[0, 2] = expected[1, 3] = expected[1, 5] = np.nan  # SIGMA = -1 rows 1 (load 0.5), 4 and 5 (load 1)
    np.testing.assert_allclose(m.y, expected, rtol=1e-12)
    assert m.missing == "mask" and m.n_missing == 3
    np.testing.assert_array_equal(m.mask, ~np.isnan(expected))
    assert m.sigma_e == 20.0 and list(m.loads) == [0.5, 1.0]


def test_pattern_and_loads_through_load_measurements(dice_files: list[Path], tmp_path: Path) -> None:
    pattern = str(tmp_path / "DICe_solution_*.txt*")
    m = torchshm.load_measurements(pattern, "dic", loads=[0.5, 1.0], scale=1e-3,
                                   columns={"strain": ["VSG_STRAIN_XX", "VSG_STRAIN_YY"]})
    assert m.lines == ("VSG_STRAIN_XX", "VSG_STRAIN_YY") and m.n == 12
    yy = m.y[:, m.line_slices()["VSG_STRAIN_YY"]]
    xx = m.y[:, m.line_slices()["VSG_STRAIN_XX"]]
    np.testing.assert_allclose(yy, -0.3 * xx, rtol=1e-3)
    with pytest.raises(ValueError, match="2 file.*but 1 load"):
        torchshm.load_measurements(pattern, "dic", loads=[0.5])
    with pytest.raises(ValueError, match="lost or absent"):
        torchshm.load_measurements(pattern, "dic", loads=[0.5, 1.0], missing="error")


def test_generic_csv_with_units_and_absent_points(tmp_path: Path) -> None:
    """A semicolon CSV with quoted names and units, strain in %, a NaN cell and a point absent
    from the second image (both masked), a 0/1 validity column."""
    head = '"x [mm]";"y [mm]";"Exx [%]";"valid"\n'
    a = head + "0;0;0.10;1\n0;5;0.20;1\n5;0;nan;1\n5;5;0.40;0\n"
    b = "title line of the export\n" + head + "5;5;0.50;1\n0;0;0.11;1\n5;0;0.31;1\n"
    (tmp_path / "a.csv").write_text(a)
    (tmp_path / "b.csv").write_text(b)
    m = read_dic([tmp_path / "a.csv", tmp_path / "b.csv"], [1.0, 2.0], preset="csv",
                 columns={"x": "x", "y": "y", "strain": "Exx", "valid": "valid"}, valid_min=1,
                 scale=1e-3, strain_scale=1e4)
    np.testing.assert_allclose(m.x, [[0, 0], [0, 0.005], [0.005, 0], [0.005, 0.005]])
    np.testing.assert_allclose(m.y, [[1000, 2000, np.nan, np.nan], [1100, np.nan, 3100, 5000]], rtol=1e-12)
    assert m.n_missing == 3


def test_round_trip_through_the_measurement_file(dice_files: list[Path], tmp_path: Path) -> None:
    m = read_dic({0.5: dice_files[0], 1.0: dice_files[1]}, scale=1e-3, sigma_e=15.0, attrs={"camera": "A"})
    for name in ("field.csv", "field.nc"):
        back = torchshm.load_measurements(m.save(tmp_path / name))
        assert back.equals(m), name


def test_malformed_exports_are_named(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("***\nSUBSET_ID,COORDINATE_X,COORDINATE_Y,SIGMA\n0,1,2,0.1\n")
    with pytest.raises(ValueError, match=r"a\.txt.*no column 'VSG_STRAIN_XX'"):
        read_dic({1.0: tmp_path / "a.txt"})
    (tmp_path / "b.txt").write_text("x,y,exx\n")
    with pytest.raises(ValueError, match="no header row naming"):
        read_dic({1.0: tmp_path / "b.txt"})
    with pytest.raises(ValueError, match="no data rows"):
        read_dic({1.0: tmp_path / "b.txt"}, preset="csv")
    (tmp_path / "c.txt").write_text("x,y,exx\n1,2,abc\n")
    with pytest.raises(ValueError, match=r"c\.txt: a row after line 1 is malformed"):
        read_dic({1.0: tmp_path / "c.txt"}, preset="csv")
    (tmp_path / "d.txt").write_text("x,y,exx,sigma\n1,2,0.1,-1\n")
    with pytest.raises(ValueError, match="no valid subset"):
        read_dic({1.0: tmp_path / "d.txt"}, preset="csv", columns={"valid": "sigma"})
    with pytest.raises(ValueError, match="unknown column role"):
        read_dic({1.0: tmp_path / "d.txt"}, columns={"exx": "a"})
    with pytest.raises(FileNotFoundError):
        read_dic(str(tmp_path / "none_*.txt"), [1.0])


def test_command_line_data_options(dice_files: list[Path]) -> None:
    """``data.format=dic``, ``data.path`` a glob relative to the run directory, ``data.dic`` the options."""
    from torchshm.cli.job import load_data
    from torchshm.config import DataConfig

    base = dice_files[0].parent
    m = load_data(DataConfig(path="DICe_solution_*", format="dic", resolution=None,
                             dic={"loads": [0.5, 1.0], "scale": 1e-3, "sigma_e": 30.0}), base)
    assert m.n == 6 and m.n_missing == 3 and m.sigma_e == 30.0
    with pytest.raises(ValueError, match="data.dic applies to format=dic"):
        load_data(DataConfig(path="DICe_solution_0.txt", format="csv", dic={"scale": 1.0}), base)


def test_every_thins_the_grid(dice_files: list[Path]) -> None:
    m = read_dic({0.5: dice_files[0], 1.0: dice_files[1]}, scale=1e-3, origin=(100, 50), every=2)
    np.testing.assert_allclose(m.x, [[0, 0], [0.02, 0]], atol=1e-12)
    np.testing.assert_allclose(m.y[0], [100.0, 300.0], rtol=1e-12)
    with pytest.raises(ValueError, match="every must be"):
        read_dic({0.5: dice_files[0]}, every=0)
