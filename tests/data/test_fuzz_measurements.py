"""Fuzz: malformed measurement files (CSV and netCDF) either load as finite, sorted data or are
refused with one ``ValueError`` line naming the file; cases found are kept below as tests."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from torchshm import load_measurements

FUZZ = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])

NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.integers(-10**6, 10**6).map(float),
    st.sampled_from([0.0, 0.1, 0.2, 39.8, 1e308, -1e308, 5e-324]),
)
TOKEN = st.one_of(
    NUMBER.map(repr), st.sampled_from(["nan", "inf", "-inf", "NaN", "", " ", "zero", "1,2", "0x10",
                                       "1e", "--1", "１", "\u00a0", "1_000", "None", '"3"']),
)
ROW = st.lists(TOKEN, min_size=0, max_size=4).map(lambda fields: ",".join(fields))
HEADER = st.sampled_from(["load,x,strain", "x,load,strain", "LOAD, X ,Strain", "load,x", "", "a,b,c",
                          "load,x,strain,extra"])
META = st.lists(st.sampled_from(["# sigma_e=0.1", "# sigma_e=abc", "# attrs={}", "# attrs={bad",
                                 "# anything", "#"]), max_size=2)


def _check(path: Path) -> None:
    try:
        m = load_measurements(path)
    except ValueError as err:
        message = str(err)
        assert "\n" not in message and str(path) in message, message
        return
    assert np.isfinite(m.y).all() and np.isfinite(m.x).all() and np.isfinite(m.loads).all()
    assert np.all(np.diff(m.x) > 0) and len(set(m.loads.tolist())) == m.loads.size
    assert m.y.shape == (m.loads.size, m.x.size)


@FUZZ
@given(meta=META, header=HEADER, rows=st.lists(ROW, max_size=12))
def test_fuzzed_csv(meta: list[str], header: str, rows: list[str]) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "campaign.csv"
        path.write_text("\n".join([*meta, header, *rows]) + "\n", encoding="utf-8")
        _check(path)


GRID = st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=5)


@settings(FUZZ, max_examples=20)
@given(x=GRID, loads=GRID, fill=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.just(1.0)),
       data=st.data())
def test_fuzzed_netcdf(x: list[float], loads: list[float], fill: float, data) -> None:
    import xarray as xr

    y = np.full((len(loads), len(x)), 1.0)
    spoil = data.draw(st.lists(st.tuples(st.integers(0, len(loads) - 1), st.integers(0, len(x) - 1)), max_size=2))
    for i, j in spoil:
        y[i, j] = fill
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "campaign.nc"
        ds = xr.Dataset({"strain": (("load", "x"), y)}, coords={"load": loads, "x": x})
        ds.to_netcdf(path, engine="h5netcdf")
        _check(path)


# ----------------------------------------------------------------- cases found, kept explicitly
@pytest.mark.parametrize("text, fragment", [
    ("load,x,strain\n", "no data rows"),
    ("load,x,strain\n39.8,0.0\n", "line 2: expected 3 values"),
    ("load,x,strain\n39.8,0.0,1.0,4\n", "line 2: expected 3 values"),
    ("load,x,strain\n39.8,0.0,1.0\n39.8,0.0,2.0\n", "appears more than once"),
    ("load,x,strain\n39.8,0.1,1.0\n39.8,0.0,2.0\n47.5,0.0,3.0\n", "no strain for load 47.5 at x = 0.1 m"),
    ("load,x,strain\n39.8,0.0,1e999\n", "line 2: strain is inf"),
    ("load,x,strain\n39.8,0.0,\u00a0\n", "line 2: malformed row"),
    ("", "no header line"),
])
def test_found_csv_cases(tmp_path: Path, text: str, fragment: str) -> None:
    path = tmp_path / "c.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=fragment) as info:
        load_measurements(path)
    assert str(path) in str(info.value)


def test_binary_csv_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match=r"c.csv: not a text file"):
        load_measurements(path)


def test_unsorted_and_duplicated_netcdf_positions_name_the_file(tmp_path: Path) -> None:
    import xarray as xr

    for x, fragment in [([0.2, 0.1], "not sorted"), ([0.1, 0.1], "repeated position")]:
        path = tmp_path / "c.nc"
        xr.Dataset({"strain": (("load", "x"), np.ones((1, 2)))}, coords={"load": [1.0], "x": x}).to_netcdf(
            path, engine="h5netcdf")
        with pytest.raises(ValueError, match=fragment) as info:
            load_measurements(path)
        assert str(path) in str(info.value)


def test_huge_csv_loads_in_seconds(tmp_path: Path) -> None:
    """100,000 readings (10 load cases x 10,000 positions), shuffled rows."""
    rng = np.random.default_rng(0)
    loads, x = np.arange(10.0), np.round(np.arange(10_000) * 0.01, 2)
    table = np.column_stack([np.repeat(loads, x.size), np.tile(x, loads.size), rng.standard_normal(loads.size * x.size)])
    path = tmp_path / "big.csv"
    with open(path, "w") as fh:
        fh.write("load,x,strain\n")
        np.savetxt(fh, table[rng.permutation(len(table))], delimiter=",", fmt="%.17g")
    t0 = time.perf_counter()
    m = load_measurements(path)
    assert m.y.shape == (10, 10_000) and time.perf_counter() - t0 < 20.0
