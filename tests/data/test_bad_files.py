"""A bad value in a measurement file is named by file, line (CSV), load case and position."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm import Measurements, load_measurements


def _csv(tmp_path: Path, rows: list[str]) -> Path:
    path = tmp_path / "campaign.csv"
    path.write_text("# sigma_e=0.1\nload,x,strain\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_nan_or_inf_strain_names_file_line_load_and_position(tmp_path: Path, value: str) -> None:
    path = _csv(tmp_path, ["39.8,0.0,1.0", "39.8,0.1,2.0", "47.5,0.0,3.0", f"47.5,0.1,{value}"])
    with pytest.raises(ValueError) as info:
        load_measurements(path)
    message = str(info.value)
    assert f"{path}, line 6: strain is {float(value)} (load 47.5, x = 0.1 m)" in message, message


def test_nan_position_names_the_column(tmp_path: Path) -> None:
    path = _csv(tmp_path, ["39.8,0.0,1.0", "39.8,nan,2.0"])
    with pytest.raises(ValueError, match=r"line 4: x is nan"):
        load_measurements(path)


def test_text_and_short_rows_name_the_line(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"line 4: malformed row \(could not convert string to float: 'zero'\)"):
        load_measurements(_csv(tmp_path, ["39.8,0.0,1.0", "39.8,zero,2.0"]))
    with pytest.raises(ValueError, match=r"line 3: expected 3 values \(load, x, strain\), got 2"):
        load_measurements(_csv(tmp_path, ["39.8,0.0"]))


def test_header_only_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no data rows after the header"):
        load_measurements(_csv(tmp_path, []))


def test_nan_in_netcdf_names_file_load_and_position(tmp_path: Path) -> None:
    import xarray as xr

    y = np.arange(6.0).reshape(2, 3)
    y[1, 2] = np.nan
    path = tmp_path / "campaign.nc"
    xr.Dataset({"strain": (("load", "x"), y)}, coords={"load": [39.8, 47.5], "x": [0.0, 0.1, 0.2]}).to_netcdf(
        path, engine="h5netcdf"
    )
    with pytest.raises(ValueError, match=r"campaign.nc: strain is nan at load 47.5, x = 0.2 m \(index \(1, 2\)\)"):
        load_measurements(path)
    Measurements(np.array([0.0, 0.1, 0.2]), np.nan_to_num(y), np.array([39.8, 47.5])).save(path)
    assert load_measurements(path).y[1, 2] == 0.0  # a good file still reads
