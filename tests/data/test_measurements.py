"""Tests of Measurements: validation, select, downsample, CSV and netCDF round trips."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import torchshm
from torchshm.data import Measurements, load_measurements


def make(L: int = 3, n: int = 41, pitch: float = 0.1, seed: int = 0) -> Measurements:
    rng = np.random.default_rng(seed)
    x = 35.0 + pitch * np.arange(n)
    loads = np.array([39.8, 47.5, 55.1, 62.8, 70.4][:L])
    return Measurements(x, rng.normal(size=(L, n)) * 10, loads, sigma_e=0.1, attrs={"truth_E_c": 35.0, "site": "705"})


def test_public_names() -> None:
    assert torchshm.Measurements is Measurements
    assert torchshm.load_measurements is load_measurements


def test_select_keeps_order_and_values() -> None:
    m = make()
    s = m.select([55.1, 39.8])
    np.testing.assert_array_equal(s.loads, [55.1, 39.8])
    np.testing.assert_array_equal(s.y, m.y[[2, 0]])
    assert m.select(47.5).y.shape == (1, m.n)


def test_downsample_every_kth_point_from_the_first() -> None:
    m = make(n=41)
    d = m.downsample(0.5)
    np.testing.assert_array_equal(d.x, m.x[::5])
    np.testing.assert_array_equal(d.y, m.y[:, ::5])
    np.testing.assert_allclose(d.x[:3], [35.0, 35.5, 36.0])
    assert d.pitch == pytest.approx(0.5)
    assert m.downsample(0.1).equals(m)
    # 351 points at 0.1 m: the paper's resolutions give 351, 176, 71, 36, 18, 9 points
    big = make(L=1, n=351)
    assert [big.downsample(r).n for r in (0.1, 0.2, 0.5, 1.0, 2.0, 4.0)] == [351, 176, 71, 36, 18, 9]


@pytest.mark.parametrize("suffix", [".csv", ".nc"])
def test_round_trip_is_exact(tmp_path: Path, suffix: str) -> None:
    m = make()
    m.y[0, 0] = 1 / 3  # a value with no short decimal form
    path = m.save(tmp_path / f"m{suffix}")
    back = load_measurements(path)
    assert back.equals(m)
    assert back.attrs == {"truth_E_c": 35.0, "site": "705"}


def test_csv_rows_in_any_order(tmp_path: Path) -> None:
    m = make(L=2, n=5)
    rows = [(float(load), float(x), float(m.y[i, j])) for i, load in enumerate(m.loads) for j, x in enumerate(m.x)]
    rows = [rows[k] for k in np.random.default_rng(1).permutation(len(rows))]
    path = tmp_path / "user.csv"
    path.write_text("x,load,strain\n" + "".join(f"{x!r},{load!r},{s!r}\n" for load, x, s in rows))
    back = load_measurements(path)
    np.testing.assert_array_equal(back.x, m.x)
    assert set(back.loads) == set(m.loads)
    np.testing.assert_array_equal(back.select(m.loads).y, m.y)


# ----------------------------------------------------------------- bad input
X = np.array([0.0, 0.1, 0.2])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(x=X, y=[[0, np.nan, 0]], loads=[1.0]), "NaN or inf"),
        (dict(x=X, y=[[0, np.inf, 0]], loads=[1.0]), "NaN or inf"),
        (dict(x=[0, np.nan, 0.2], y=[[0, 0, 0]], loads=[1.0]), "NaN or inf"),
        (dict(x=X, y=[[0, 0]], loads=[1.0]), "shape"),
        (dict(x=X, y=[0, 0, 0], loads=[1.0]), "y must be 2-D"),
        (dict(x=X, y=[[0, 0, 0]], loads=[1.0, 2.0]), "shape"),
        (dict(x=[0.0, 0.2, 0.1], y=[[0, 0, 0]], loads=[1.0]), "not sorted"),
        (dict(x=[0.0, 0.1, 0.1], y=[[0, 0, 0]], loads=[1.0]), "repeated position"),
        (dict(x=X, y=[[0, 0, 0], [1, 1, 1]], loads=[1.0, 1.0]), "repeated load"),
        (dict(x=X, y=[[0, 0, 0]], loads=[1.0], sigma_e=-0.1), "sigma_e"),
    ],
)
def test_bad_input_names_the_problem(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Measurements(**kwargs)


def test_resolution_not_a_multiple_of_the_pitch() -> None:
    with pytest.raises(ValueError, match="not a whole multiple of the pitch"):
        make().downsample(0.25)
    with pytest.raises(ValueError, match="not a whole multiple of the pitch"):
        make().downsample(0.05)


def test_downsample_irregular_positions() -> None:
    m = Measurements([0.0, 0.1, 0.3], [[0, 0, 0]], [1.0])
    with pytest.raises(ValueError, match="not equally spaced"):
        m.downsample(0.2)


def test_select_unknown_load() -> None:
    with pytest.raises(ValueError, match="unknown load case 99.9"):
        make().select([39.8, 99.9])


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="not found"):
        load_measurements(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("load,x,strain\n39.8,0.0,abc\n")
    with pytest.raises(ValueError, match="malformed row"):
        load_measurements(bad)
    bad.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(ValueError, match="header"):
        load_measurements(bad)
    bad.write_text("load,x,strain\n39.8,0.0,1\n39.8,0.1,1\n47.5,0.0,1\n")
    with pytest.raises(ValueError, match="no strain for load 47.5 at x = 0.1"):
        load_measurements(bad)
    bad.write_text("load,x,strain\n39.8,0.0,1\n39.8,0.0,2\n")
    with pytest.raises(ValueError, match="more than once"):
        load_measurements(bad)
    nc = tmp_path / "bad.nc"
    nc.write_bytes(b"not a netcdf file")
    with pytest.raises(ValueError, match="not a readable netCDF"):
        load_measurements(nc)
    with pytest.raises(ValueError, match="unknown measurement file type"):
        load_measurements(bad.rename(tmp_path / "bad.txt"))


def test_edge_inputs_give_named_errors(tmp_path: Path) -> None:
    m = make()
    for bad in (float("nan"), float("inf"), -0.1, 0.0):
        with pytest.raises(ValueError, match="not a whole multiple of the pitch"):
            m.downsample(bad)
    np.testing.assert_array_equal(m.select(np.array(39.8)).loads, [39.8])
    with pytest.raises(ValueError, match="load cases must be numbers"):
        m.select(["abc"])
    numpy_attrs = Measurements(m.x, m.y, m.loads, attrs={"n": np.int64(3), "e": np.float64(35.0)})
    back = load_measurements(numpy_attrs.save(tmp_path / "a.csv"))
    assert back.attrs == {"n": 3, "e": 35.0}
