"""Measurements with sensor lines, coordinates, masked dropouts and per-line noise; their files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm.data import Measurements, load_measurements


def two_lines(missing: str = "mask") -> Measurements:
    """Two fibres, 'top' at 0.1 m and 'bottom' at 0.2 m, the same x on both, 3 load cases."""
    x = np.concatenate([np.round(0.1 * np.arange(9), 10), np.round(0.2 * np.arange(5), 10)])
    line = ["top"] * 9 + ["bottom"] * 5
    y = np.arange(3 * 14, dtype=float).reshape(3, 14) / 3
    if missing == "mask":
        y[0, 2] = y[1, 10] = y[2, 3] = np.nan
    return Measurements(x, y, [39.8, 47.5, 55.1], sigma_e={"top": 0.1, "bottom": 0.25},
                        attrs={"site": "705"}, line=line, missing=missing)


def test_lines_blocks_mask_and_noise() -> None:
    m = two_lines()
    assert m.lines == ("top", "bottom") and m.n == 14
    assert m.line_slices() == {"top": slice(0, 9), "bottom": slice(9, 14)}
    assert m.n_missing == 3 and m.mask.shape == (3, 14) and not m.mask[0, 2] and m.mask[0, 1]
    assert m.sigma_e_of("bottom") == 0.25
    assert m.pitch is None  # two pitches
    assert "2 lines [top, bottom]" in repr(m) and "3 missing (masked)" in repr(m)
    assert "line 'bottom': 5 positions 0..0.8 m, pitch 0.2 m, sigma_e=0.25 µε, 1 of 15" in m.summary()


def test_one_fibre_unchanged() -> None:
    m = Measurements([0.0, 0.1, 0.2], [[1.0, 2.0, 3.0]], [39.8])
    assert m.line is None and m.lines == (None,) and m.n_missing == 0 and m.mask.all()
    assert m.sigma_e == 0.1 and m.missing == "error"
    assert repr(m) == "Measurements(1 load cases [39.8], 3 positions 0..0.2 m, pitch 0.1 m, sigma_e=0.1 µε)"


def test_format_names_and_exports(tmp_path: Path) -> None:
    import torchshm.data

    m = two_lines()
    assert load_measurements(m.save(tmp_path / "m.txt.csv"), format="CSV").equals(m)
    assert torchshm.data.flag_anomalies(m, threshold=1e3).n_missing == m.n_missing


def test_select_and_downsample_per_line() -> None:
    m = two_lines()
    s = m.select([55.1, 39.8])
    np.testing.assert_array_equal(s.y, m.y[[2, 0]])
    assert s.n_missing == 2 and s.lines == m.lines
    d = m.downsample(0.4)
    np.testing.assert_allclose(d.x, [0.0, 0.4, 0.8, 0.0, 0.4, 0.8])
    np.testing.assert_array_equal(d.line, ["top"] * 3 + ["bottom"] * 3)
    np.testing.assert_array_equal(d.y, m.y[:, [0, 4, 8, 9, 11, 13]])
    with pytest.raises(ValueError, match="not a whole multiple of the pitch 0.2 m on line 'bottom'"):
        m.downsample(0.3)


def test_nan_refused_with_count_place_and_hint() -> None:
    y = two_lines().y
    with pytest.raises(ValueError) as info:
        Measurements(two_lines().x, y, [39.8, 47.5, 55.1], line=two_lines().line)
    message = str(info.value)
    assert "3 NaN or inf value(s), first at load 39.8, x = 0.2 m on line 'top' (index (0, 2))" in message
    assert "missing='mask'" in message and "\n" not in message


@pytest.mark.parametrize("kwargs, fragment", [
    (dict(line=["a", "b", "a"]), "not contiguous"),
    (dict(line=["a", 1, "b"]), "all int or all str"),
    (dict(line=["a", "a,b", "c"]), "commas"),
    (dict(line=["a", "a"]), "2 labels"),
    (dict(line=["a", "a", "b"], sigma_e={"a": 0.1}), "sigma_e names lines"),
    (dict(sigma_e={"a": 0.1}), "needs line labels"),
    (dict(line=["a", "a", "b"], sigma_e={"a": 0.1, "b": -1}), r"sigma_e\['b'\]"),
    (dict(missing="drop"), "missing must be"),
    (dict(y=[[0, np.inf, 1]], missing="mask"), "NaN or inf"),
    (dict(y=[[np.nan] * 3], missing="mask"), "no valid reading"),
])
def test_bad_lines_name_the_problem(kwargs: dict, fragment: str) -> None:
    args = dict(x=[0.0, 0.1, 0.2], y=[[0.0, 1.0, 2.0]], loads=[1.0]) | kwargs
    with pytest.raises(ValueError, match=fragment):
        Measurements(**args)


def test_same_x_on_two_lines_and_sorting_within_a_line() -> None:
    Measurements([0.0, 0.1, 0.0, 0.1], [[1, 2, 3, 4]], [1.0], line=[1, 1, 2, 2])
    with pytest.raises(ValueError, match="not sorted .*on line 2"):
        Measurements([0.0, 0.1, 0.1, 0.0], [[1, 2, 3, 4]], [1.0], line=[1, 1, 2, 2])


def test_field_coordinates() -> None:
    x = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.1], [0.1, 0.1]])
    m = Measurements(x, [[1, 2, 3, np.nan]], [1.0], missing="mask")
    assert m.n == 4 and m.pitch is None and "2-D field" in repr(m)
    with pytest.raises(ValueError, match="cannot downsample a field"):
        m.downsample(0.2)
    with pytest.raises(ValueError, match="repeated point"):
        Measurements(x[[0, 0]], [[1, 2]], [1.0])
    with pytest.raises(ValueError, match="d = 2 or 3"):
        Measurements(np.zeros((2, 4)), [[1, 2]], [1.0])


@pytest.mark.parametrize("suffix", [".csv", ".nc"])
@pytest.mark.parametrize("case", ["lines", "int_lines", "field", "one_fibre_masked"])
def test_extended_round_trip_is_exact(tmp_path: Path, suffix: str, case: str) -> None:
    if case == "lines":
        m = two_lines()
    elif case == "int_lines":
        m = Measurements([0.0, 0.1, 0.0], [[1 / 3, np.nan, 2.0]], [39.8], line=[7, 7, 3], missing="mask")
    elif case == "field":
        m = Measurements([[0.0, 0.0, 1.0], [0.1, 0.0, 1.0]], [[1.0, 2.0], [3.0, np.nan]], [1.0, 2.0],
                         line=["a", "a"], missing="mask")
    else:
        m = Measurements([0.0, 0.1, 0.2], [[1.0, np.nan, 3.0]], [39.8], sigma_e=0.3, missing="mask")
    back = load_measurements(m.save(tmp_path / f"m{suffix}"))
    assert back.equals(m), (repr(back), repr(m))
    if case == "lines":
        with pytest.raises(ValueError, match="3 NaN or inf value"):
            load_measurements(tmp_path / f"m{suffix}", missing="error")


def test_user_long_csv_with_lines_and_absent_rows(tmp_path: Path) -> None:
    path = tmp_path / "user.csv"
    path.write_text("line,load,x,strain\nB,2,0.0,5\nA,1,0.1,2\nA,1,0.0,1\nB,1,0.0,3\nA,2,0.0,4\n")
    with pytest.raises(ValueError, match=r"no strain for load 2 at x = 0.1 m on line 'A' \(1 absent"):
        load_measurements(path)
    m = load_measurements(path, missing="mask")
    assert m.lines == ("B", "A") and m.loads.tolist() == [2.0, 1.0]
    np.testing.assert_array_equal(m.x, [0.0, 0.0, 0.1])
    np.testing.assert_array_equal(m.y, [[5, 4, np.nan], [3, 1, 2]])
    path.write_text("line,load,x,strain,extra\nA,1,0.0,1,2\n")
    with pytest.raises(ValueError, match=r"user.csv: header must name the columns \[line,\] load, x"):
        load_measurements(path)
    path.write_text("line,load,x,strain\nA,1,0.0\n")
    with pytest.raises(ValueError, match="user.csv: line 2: expected 4 values"):
        load_measurements(path)


def test_old_files_and_old_messages_unchanged(tmp_path: Path) -> None:
    m = Measurements([0.0, 0.1], [[1.0, 2.0]], [39.8])
    path = m.save(tmp_path / "m.csv")
    assert "line" not in path.read_text() and load_measurements(path).equals(m)
    path.write_text("load,x,strain\n39.8,0.0,nan\n39.8,0.1,1\n")
    with pytest.raises(ValueError, match="line 2: strain is nan .*missing='mask' treats NaN readings as dropouts"):
        load_measurements(path)
    masked = load_measurements(path, missing="mask")
    assert masked.n_missing == 1 and masked.missing == "mask"


def test_fuzzed_extended_csv_loads_or_names_the_file() -> None:
    """Malformed extended CSVs end in one ValueError line naming the file (Hypothesis)."""
    import tempfile

    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    token = st.sampled_from(["A", "B", "1", "2", "0.0", "0.1", "nan", "inf", "", "x", "1e999", " A"])
    rows = st.lists(st.lists(token, min_size=3, max_size=5).map(",".join), max_size=8)
    header = st.sampled_from(["line,load,x,strain", "line,load,x,y,strain", "line,load,x,z,strain",
                              "load,x,y,strain", "line,line,x,strain"])
    meta = st.lists(st.sampled_from(["# missing=mask", "# lines=[\"A\"]", "# lines=[", "# sigma_e_by_line=[[\"A\", 1]]",
                                     "# sigma_e_by_line=x", "# lines=5", "# sigma_e_by_line=[1]",
                                     "# lines=[{}]"]), max_size=2)
    header = st.one_of(header, st.just("load,x,strain"))

    @settings(max_examples=60, derandomize=True, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(meta=meta, header=header, rows=rows, missing=st.sampled_from([None, "mask"]))
    def check(meta: list[str], header: str, rows: list[str], missing: str | None) -> None:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "c.csv"
            path.write_text("\n".join([*meta, header, *rows]) + "\n", encoding="utf-8")
            try:
                m = load_measurements(path, missing=missing)
            except ValueError as err:
                assert "\n" not in str(err) and str(path) in str(err), str(err)
                return
            assert m.y.shape == (m.loads.size, m.n) and not np.isinf(m.y).any()

    check()
