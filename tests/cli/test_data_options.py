"""``data.format``, ``data.missing``, ``data.lines`` and ``data.odisi`` of ``torchshm-identify``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm import Measurements
from torchshm.cli.job import load_data
from torchshm.config import DataConfig


@pytest.fixture
def masked_file(tmp_path: Path) -> Path:
    x = np.round(np.arange(35.0, 36.0, 0.1), 9)
    y = np.arange(20.0).reshape(2, 10)
    y[0, 3] = np.nan
    m = Measurements(np.concatenate([x, x]), np.hstack([y, -y]), [39.8, 47.5], line=["b"] * 10 + ["t"] * 10,
                     missing="mask")
    m.save(tmp_path / "two.csv")
    return tmp_path / "two.csv"


def test_a_file_with_lines_and_dropouts(masked_file: Path) -> None:
    m = load_data(DataConfig(path=masked_file.name, format="CSV", resolution=0.1), masked_file.parent)
    assert m.lines == ("b", "t") and m.n_missing == 2


def test_missing_mask_reads_nan_of_a_plain_file(tmp_path: Path) -> None:
    (tmp_path / "plain.csv").write_text("load,x,strain\n39.8,35,1.0\n39.8,35.1,nan\n")
    with pytest.raises(ValueError, match="missing='mask'"):
        load_data(DataConfig(path="plain.csv", resolution=None), tmp_path)
    m = load_data(DataConfig(path="plain.csv", missing="mask", resolution=None), tmp_path)
    assert m.n_missing == 1


def test_options_that_do_not_apply_are_refused(masked_file: Path) -> None:
    with pytest.raises(ValueError, match="data.lines and data.odisi apply to format=odisi"):
        load_data(DataConfig(path=str(masked_file), lines={"top": "seg"}), masked_file.parent)
    with pytest.raises(ValueError, match="apply to a file"):
        load_data(DataConfig(format="csv"), masked_file.parent)


def test_an_odisi_export(tmp_path: Path) -> None:
    """``data.lines`` names the ODiSI segments (or x ranges), ``data.odisi`` the other options."""
    rows = ["Test name:\tdeck", "Units:\tmicrostrain", "-" * 20,
            "Gage/Segment Name\t\t\ttop[0]\ttop[1]\ttop[2]", "x-axis\t\t\t1.0\t1.5\t2.0", "tare\t\t\t0.0\t0.0\t0.0",
            "2024-05-02 10:00:00.000000\tmeasurement\tstrain\t1.0\t\t3.0",
            "2024-05-02 10:05:00.000000\tmeasurement\tstrain\t4.0\t5.0\t6.0"]
    (tmp_path / "run.tsv").write_text("\n".join(rows) + "\n")
    windows = {39.8: ["2024-05-02 09:59:59", "2024-05-02 10:00:01"], 47.5: ["2024-05-02 10:04:59", "2024-05-02 10:05:01"]}
    for lines in ({"deck": "top"}, {"deck": [0.9, 2.1]}):
        m = load_data(DataConfig(path="run.tsv", lines=lines, missing="mask", odisi={"windows": windows},
                                 resolution=None), tmp_path)
        assert m.lines == ("deck",) and m.n_missing == 1
        np.testing.assert_array_equal(m.y, [[1.0, np.nan, 3.0], [4.0, 5.0, 6.0]])
